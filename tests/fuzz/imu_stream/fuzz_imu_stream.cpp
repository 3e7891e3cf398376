// HID IMU reports as the firmware reads them, through firmware::ImuInputDecoder (the counter, time
// and status checks and the queue). Input: records of [length byte][4-byte receive-time step, us,
// LE][length bytes of report]. Properties: every report lands in exactly one count, a sample only
// leaves the queue once, the samples handed on are finite and strictly increasing in time.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>

#include "firmware/wire/imu_input_decoder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc;
  static auto decoder = std::make_unique<firmware::ImuInputDecoder>();
  *decoder = firmware::ImuInputDecoder(1'700'000'000'000'000'000LL);
  std::int64_t rx_ns = 1'700'000'000'100'000'000LL;
  bool have_last = false;
  double last_t = 0.0;
  std::size_t at = 0;
  while (at + 5 <= size) {
    const std::size_t n = data[at] % 40;
    const std::uint32_t step_us = static_cast<std::uint32_t>(data[at + 1]) | (static_cast<std::uint32_t>(data[at + 2]) << 8) |
                                  (static_cast<std::uint32_t>(data[at + 3]) << 16) |
                                  (static_cast<std::uint32_t>(data[at + 4]) << 24);
    at += 5;
    if (at + n > size) break;
    rx_ns += static_cast<std::int64_t>(step_us) * 1000;
    decoder->decode(std::span<const std::uint8_t>(data + at, n), rx_ns);
    at += n;
    ImuInput s;
    while (decoder->take(s)) {
      if (!std::isfinite(s.t) || (have_last && !(s.t > last_t))) std::abort();
      for (int k = 0; k < 3; ++k)
        if (!std::isfinite(s.gyro[k]) || !std::isfinite(s.accel[k])) std::abort();
      have_last = true;
      last_t = s.t;
    }
  }
  const firmware::ImuCounters& c = decoder->counters();
  if (c.reports != c.samples + c.rejected() || c.handed != c.samples || decoder->pending() != 0) std::abort();
  return 0;
}
