// Point-cloud datagrams -> clouds: the endpoint check (ego scans only on the ego endpoint, map
// shares and signatures only on the V2X one), the static reassembler, and the completed cloud's
// checks (sensor pose, sender, size): an ego scan is dequantized into a localizer input once its
// time stamp is plausible against the local clock; a map share is handed on as it arrived, for the
// share-verification queue (share_verification_queue.hpp). Never calls the localizer.
// Allocation-free; the reassembler and the decoded scan's buffers are inside: make the object static.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "firmware/protocol/pointcloud_udp.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

inline constexpr std::size_t kReassemblySlots = 4;                 // clouds in flight at once
inline constexpr std::size_t kMaxCloudPoints = config::kMaxScanPoints;
inline constexpr std::size_t kMaxCloudFragments = 2048;            // >= 131072 / 143 points
using CloudReassembler = protocol::StaticPointCloudReassembler<kReassemblySlots, kMaxCloudPoints, kMaxCloudFragments>;

// kEgoRejected: an ego scan refused for its time stamp; it still consumes a frame index
// (DecodedCloud::frame_index), and the caller publishes the last pose again for it (a pose every
// frame, nothing new fused).
// kMapShare: a completed map share with a usable pose, not yet admitted (CloudInputDecoder's
// result only: InputDecoder hands it to the ShareVerificationQueue, which answers kMapQueued,
// kMapPaced or kRejected).
// kMapQueued: a map share passed the cheap trust checks and waits for its signature verification
// (ShareVerificationQueue::next_verified_share()); nothing to fuse yet.
// kMapPaced: a map share the map would not fuse, known from its first fragment (the queue's share
// filter): neither hashed nor verified.
enum class CloudKind : std::uint8_t { kNone, kEgoScan, kMapCloud, kRejected, kEgoRejected, kMapQueued, kMapPaced, kMapShare };

// Which endpoint a datagram came in on. Ego sensors have their own socket: an ego scan on the V2X
// endpoint, or a map share / signature on the ego endpoint, is rejected (counted) before it
// reaches the reassembler.
enum class DatagramChannel : std::uint8_t { kEgo, kV2x };

// Ego scans must carry a time stamp within this of the local (disciplined) clock: one scan dated
// far in the future would otherwise make every later real scan look stale to the localizer.
inline constexpr std::int64_t kEgoScanMaxClockSkewNs = 500'000'000;  // [ns] 5 sweep periods

// One completed cloud: `map` is set for kMapCloud (kMapShare: only its time and pose), `ego` for
// kEgoScan. The point spans refer to CloudInputDecoder's buffers (an ego scan's: valid until the
// next ego scan is decoded) or to ShareVerificationQueue's (a map cloud's: see next_verified_share()).
struct DecodedCloud {
  CloudKind kind = CloudKind::kNone;
  MapCloudInput map{};
  EgoScanInput ego{};
  std::uint32_t frame_index = 0;  // kEgoScan: ego scans decoded before this one
  bool gnss_used = false;         // kEgoScan: a GNSS fix was decoded since the previous ego scan (pose flag GnssUsed)
};

// What one datagram did.
struct DatagramResult {
  bool completed = false;  // it completed a cloud: take it with decode_completed() before the next datagram
  bool signature = false;  // a signature datagram on the V2X endpoint, for the share verifier
  // A map-share fragment the reassembler placed (its payload is what the share's signature covers),
  // with the header's time in localizer seconds; nullptr otherwise.
  const protocol::AcceptedFragment* share_fragment = nullptr;
  double share_t = 0.0;
};

struct CloudCounters {
  std::uint64_t datagrams = 0;
  std::uint64_t datagrams_rejected = 0;  // any reassembler status other than ok/complete/duplicate/stale
  std::uint64_t wrong_channel = 0;       // datagram type not allowed on the endpoint it came in on
  std::uint64_t ego_scans = 0;
  std::uint64_t clouds_rejected = 0;     // complete but unusable (bad pose, wrong message type or sender)
  std::uint64_t ego_time_rejected = 0;   // ego scans dated implausibly far from the local clock / not newer
};

class CloudInputDecoder {
 public:
  // epoch_ns: disciplined time that maps to localizer time 0 (see localizer_time_s).
  explicit CloudInputDecoder(std::int64_t epoch_ns = 0) : epoch_ns_(epoch_ns) {}
  void set_epoch_ns(std::int64_t epoch_ns) { epoch_ns_ = epoch_ns; }
  std::int64_t epoch_ns() const { return epoch_ns_; }

  // One datagram received at monotonic now_ns on `channel`. local_time_ns: the disciplined clock
  // now (the plausibility of an ego scan's time stamp).
  DatagramResult on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns, std::int64_t local_time_ns,
                             DatagramChannel channel);
  // The endpoint a datagram belongs on, from its message type (an offline event stream has no sockets).
  static DatagramChannel channel_of(std::span<const std::uint8_t> datagram);

  // The cloud the last datagram completed (kNone when there is none; a cloud is returned once):
  // kEgoScan, kEgoRejected, kMapShare (then completed_cloud() holds it) or kRejected.
  DecodedCloud decode_completed();
  // The same, with the local (disciplined) clock read again after the caller drained the CAN
  // frames received before the cloud's last fragment (the emulated clock moves with them).
  DecodedCloud decode_completed(std::int64_t local_time_ns);
  // The reassembled cloud behind the last kMapShare, valid until the next datagram.
  const protocol::ReassembledCloud& completed_cloud() const { return reassembler_.completed(); }
  // The local clock the last completed cloud was judged by (its period boundary, for an ego scan).
  std::int64_t completed_local_time_ns() const { return completed_local_time_ns_; }

  // Frees reassembly slots idle too long (monotonic now_ns); returns how many.
  std::size_t expire(std::int64_t now_ns) { return reassembler_.expire(now_ns); }

  const CloudCounters& counters() const { return counters_; }
  const protocol::ReassemblyCounters& reassembly_counters() const { return reassembler_.counters(); }

 private:
  DecodedCloud decode_ego_scan(const protocol::ReassembledCloud& cloud, const Mat4d& body_T_lidar, double t);
  // Plausible time: near the local clock and newer than the last accepted scan.
  bool ego_time_plausible(std::uint64_t stamp_ns) const;

  std::int64_t epoch_ns_ = 0;
  CloudReassembler reassembler_{};
  std::array<Vec3f, kMaxCloudPoints> points_{};
  std::array<float, kMaxCloudPoints> point_times_{};
  bool completed_pending_ = false;
  std::int64_t completed_local_time_ns_ = 0;
  bool have_ego_time_ = false;
  std::uint64_t last_ego_stamp_ns_ = 0;
  std::uint32_t ego_frames_ = 0;  // ego frames consumed (fused or refused for their time)
  CloudCounters counters_{};
};

// The wire sensor pose as a 4x4 transform; false for a non-unit quaternion or a non-finite position.
bool sensor_pose_matrix(const protocol::SensorPose& pose, Mat4d& out);
// A reassembled cloud's first out.size() points (cloud.xyz as decoded by the reassembler) as Vec3f.
void copy_cloud_points(const protocol::ReassembledCloud& cloud, std::span<Vec3f> out);

}  // namespace v2xloc::firmware
