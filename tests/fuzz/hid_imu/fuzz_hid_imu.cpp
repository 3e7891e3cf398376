// USB HID IMU input reports (hal/HID_IMU_REPORT.md): a report decodes or is kMalformed; a decoded
// report re-encodes to the same bytes (but the reserved byte 3, which receivers ignore) and
// converts to finite SI values.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "hal/hid_imu_report.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::hal;
  hid_imu::RawReport report;
  if (hid_imu::decode_input_report({data, size}, report) != Status::kOk) return 0;
  std::uint8_t again[hid_imu::kInputReportBytes] = {};
  if (hid_imu::encode_input_report(report, again) != size || std::memcmp(again, data, 3) != 0 ||
      std::memcmp(again + 4, data + 4, size - 4) != 0)
    std::abort();
  const hid_imu::Sample s = hid_imu::to_si(report);
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(s.gyro_rad_s[k]) || !std::isfinite(s.accel_m_s2[k])) std::abort();
  return 0;
}
