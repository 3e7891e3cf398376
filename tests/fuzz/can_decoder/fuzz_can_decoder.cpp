// Bytes from the CAN bus and the point-cloud socket through the firmware's own path: SocketCAN
// `struct can_frame` bytes -> hal::decode_socketcan_frame -> InputDecoder::decode_can, interleaved
// with datagrams -> InputDecoder::on_datagram / decode_completed (the firmware's input order).
// Input: records of [tag][payload]: tag even -> 16 bytes of can_frame; tag odd -> 2-byte length +
// that many datagram bytes. Properties: every input is counted exactly once, and whatever the
// decoder hands on to the localizer is finite and within the decoder's buffers.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <span>

#include "firmware/wire/input_decoder.hpp"
#include "hal/socketcan_frame.hpp"

namespace {

using namespace v2xloc;

bool finite_points(std::span<const Vec3f> points) {
  if (points.size() > firmware::kMaxCloudPoints) return false;
  for (const Vec3f& p : points)
    if (!p.allFinite()) return false;
  return true;
}

void check(const firmware::DecodedCan& d) {
  using K = firmware::CanInputKind;
  if (d.kind == K::kVehicle && !(std::isfinite(d.vehicle.wheel_speed) && std::isfinite(d.vehicle.yaw_rate)))
    std::abort();
  if (d.kind == K::kGnssFix && !(std::isfinite(d.gnss.lat_deg) && std::isfinite(d.gnss.lon_deg) &&
                                 std::isfinite(d.gnss.alt_m) && std::isfinite(d.gnss.h_acc)))
    std::abort();
}

void check(const firmware::DecodedCloud& d) {
  if (d.kind == firmware::CloudKind::kMapCloud && (!finite_points(d.map.points) || !d.map.world_T_sensor.matrix().allFinite()))
    std::abort();
  if (d.kind == firmware::CloudKind::kEgoScan &&
      (!finite_points(d.ego.points) || !d.ego.body_T_lidar.matrix().allFinite() ||
       (!d.ego.point_times.empty() && d.ego.point_times.size() != d.ego.points.size())))
    std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Megabytes of buffers: one decoder for the process, re-created in place per input (assigning
  // a fresh InputDecoder would put that temporary on the stack and overflow it).
  static auto* decoder = new firmware::InputDecoder(0);
  decoder->~InputDecoder();
  new (decoder) firmware::InputDecoder(0);
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
        check(decoder->decode_can(rx.frame, now_ns));
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
      if (decoder->on_datagram({data, len}, now_ns)) {
        const firmware::DecodedCloud d = decoder->decode_completed();
        check(d);
        // As the firmware: an ego scan closes the period, queued shares are verified (bounded).
        if (d.kind == firmware::CloudKind::kEgoScan || d.kind == firmware::CloudKind::kEgoRejected) {
          for (std::size_t k = 0; k < firmware::kMaxSignatureVerificationsPerPeriod; ++k) {
            const firmware::DecodedCloud share = decoder->next_verified_share();
            if (share.kind == firmware::CloudKind::kNone) break;
            check(share);
          }
        }
      }
      data += len;
      size -= len;
    }
  }
  if (decoder->can().counters().can_frames != frames || decoder->clouds().counters().datagrams != datagrams) std::abort();
  return 0;
}
