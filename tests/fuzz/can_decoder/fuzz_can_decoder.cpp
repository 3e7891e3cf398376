// Bytes from the CAN bus and the point-cloud socket through the firmware's own path: SocketCAN
// `struct can_frame` bytes -> hal::decode_socketcan_frame -> InputDecoder::on_can, interleaved with
// datagrams -> InputDecoder::on_datagram / dispatch_completed (as FirmwareApp polls them).
// Input: records of [tag][payload]: tag even -> 16 bytes of can_frame; tag odd -> 2-byte length +
// that many datagram bytes. Every input is counted exactly once by the decoder.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "firmware/app/input_decoder.hpp"
#include "hal/socketcan_frame.hpp"

namespace {

using namespace v2xloc;

// Stands in for the localizer: accepts everything, returns a fixed frame output.
class NullPort final : public firmware::LocalizerPort {
 public:
  void on_vehicle(const VehicleInput&) override { ++inputs; }
  void on_gnss(const GnssInput&) override { ++inputs; }
  MapInsertResult on_map_cloud(const MapCloudInput&) override {
    ++inputs;
    return {};
  }
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput&) override {
    ++inputs;
    return output_;
  }
  std::size_t inputs = 0;

 private:
  LocalizerFrameOutput output_{};
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Megabytes of static buffers: one decoder for the process, re-created in place per input.
  static auto* decoder = new firmware::InputDecoder(0);
  *decoder = firmware::InputDecoder(0);
  NullPort port;
  std::int64_t now_ns = 1'000'000'000;
  std::uint64_t frames = 0, datagrams = 0;
  while (size > 0) {
    const std::uint8_t tag = data[0];
    ++data;
    --size;
    now_ns += 10'000'000;
    if (tag % 2 == 0) {
      const std::size_t n = size < hal::kSocketCanFrameBytes ? size : hal::kSocketCanFrameBytes;
      hal::CanRxFrame rx;
      if (hal::decode_socketcan_frame({data, n}, rx) == hal::Status::kOk && !rx.error && !rx.remote) {
        decoder->on_can(rx.frame, now_ns, port);
        ++frames;
      }
      data += n;
      size -= n;
    } else {
      if (size < 2) break;
      std::size_t len = static_cast<std::size_t>(data[0] | (data[1] << 8)) % 1500;
      data += 2;
      size -= 2;
      if (len > size) len = size;
      ++datagrams;
      if (decoder->on_datagram({data, len}, now_ns)) decoder->dispatch_completed(port);
      data += len;
      size -= len;
    }
  }
  const auto& c = decoder->counters();
  if (c.can_frames != frames || c.datagrams != datagrams) std::abort();
  return 0;
}
