// Wire -> localizer inputs. CAN frames (vehicle motion, GNSS position/status/velocity/DOP/time) are decoded with
// the DBC codec; point-cloud datagrams are reassembled and dequantized into an ego scan or a map
// share. The decoder RETURNS typed inputs and never calls the localizer: the period driver
// (period_driver.hpp) does, for the firmware loop, the replayer's in-process path and the
// offline evaluator alike, so every path applies exactly the firmware's decoding and checks.
//
// Input order (the firmware's contract; every other path follows it): a completed cloud is handed
// to the localizer only after every CAN frame received before its last fragment, so per ego frame
// the localizer sees CAN inputs (receive order), then map clouds, then the ego scan.
// Allocation-free; all storage (reassembler, decoded cloud) is inside: make the object static.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "firmware/protocol/can_messages.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/trust/map_share_verifier.hpp"
#include "firmware/wire/share_schedule.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

inline constexpr std::size_t kReassemblySlots = 4;                 // clouds in flight at once
inline constexpr std::size_t kMaxCloudPoints = config::kMaxScanPoints;
inline constexpr std::size_t kMaxCloudFragments = 2048;            // >= 131072 / 143 points
using CloudReassembler = protocol::StaticPointCloudReassembler<kReassemblySlots, kMaxCloudPoints, kMaxCloudFragments>;

enum class CanInputKind : std::uint8_t {
  kVehicle,       // decoded a VehicleInput
  kGnssFix,       // decoded a GnssInput (on the time frame that closes a fix)
  kGnssPart,      // position half, status, velocity or DOP of a fix, stored until the time frame
  kInvalid,       // decoded, but flagged invalid by the sender, or a position half that pairs with
                  // nothing, or a time frame closing a fix without status (counted, not forwarded)
  kRejected,      // wrong DLC, CRC or range, or a repeated rolling counter (counted)
  kUnknownId,     // not ours (counted)
};

// kEgoRejected: an ego scan refused for its time stamp; it still consumes a frame index
// (DecodedCloud::frame_index), and the caller publishes the last pose again for it (a pose every
// frame, nothing new fused).
// kMapQueued: a map share passed the cheap trust checks and waits for its signature verification
// (InputDecoder::next_verified_share()); nothing to fuse yet.
// kMapPaced: a map share the map would not fuse, known from its first fragment (the decoder's share
// filter): neither hashed nor verified.
enum class CloudKind : std::uint8_t { kNone, kEgoScan, kMapCloud, kRejected, kEgoRejected, kMapQueued, kMapPaced };

// Which endpoint a datagram came in on. Ego sensors have their own socket: an ego scan on the V2X
// endpoint, or a map share / signature on the ego endpoint, is rejected (counted) before it
// reaches the reassembler.
enum class DatagramChannel : std::uint8_t { kEgo, kV2x };

// Ego scans must carry a time stamp within this of the local (disciplined) clock: one scan dated
// far in the future would otherwise make every later real scan look stale to the localizer.
inline constexpr std::int64_t kEgoScanMaxClockSkewNs = 500'000'000;  // [ns] 5 sweep periods

// One decoded CAN frame: `vehicle` is set for kVehicle, `gnss` for kGnssFix.
struct DecodedCan {
  CanInputKind kind = CanInputKind::kUnknownId;
  VehicleInput vehicle{};
  GnssInput gnss{};
};

// One completed cloud: `map` is set for kMapCloud, `ego` for kEgoScan. The point spans refer to
// the decoder's buffers and stay valid until the next datagram.
struct DecodedCloud {
  CloudKind kind = CloudKind::kNone;
  MapCloudInput map{};
  EgoScanInput ego{};
  std::uint32_t frame_index = 0;  // kEgoScan: ego scans decoded before this one
  bool gnss_used = false;         // kEgoScan: a GNSS fix was decoded since the previous ego scan (pose flag GnssUsed)
};

// Asked before a queued share's signature is verified: would the map fuse this source's cloud of
// time t? The source id is the provisioned signer's, so a forged header cannot name another.
class MapShareWanted {
 public:
  virtual bool wants(std::uint32_t source_id, double t) const = 0;
  // Asked next for an infrastructure share: would its cloud pass its unit's surveyed background?
  // One that would not is refused before its signature check (no ECDSA spent, counted).
  virtual bool fits_background(std::uint32_t /*source_id*/, const Mat4d& /*world_T_sensor*/,
                               std::span<const Vec3f> /*points*/) const {
    return true;
  }
  // True while the localizer has no map: the period that builds it is the heaviest, so the
  // signatures of the shares it will fuse are checked earlier, as they complete.
  virtual bool awaiting_first_map() const { return false; }

 protected:
  ~MapShareWanted() = default;
};

struct DecoderCounters {
  std::uint64_t can_frames = 0;
  std::uint64_t vehicle_inputs = 0;
  std::uint64_t vehicle_invalid = 0;
  std::uint64_t gnss_inputs = 0;
  std::uint64_t gnss_incomplete = 0;   // time frame without the fix's status frame
  std::uint64_t gnss_position_dropped = 0;  // 0x130 halves that formed no position (GnssPositionPairer)
  std::uint64_t can_rejected = 0;      // DLC / CRC / range failures
  std::uint64_t can_unknown_id = 0;
  std::uint64_t datagrams = 0;
  std::uint64_t datagrams_rejected = 0;  // any reassembler status other than ok/complete/duplicate/stale
  std::uint64_t ego_scans = 0;
  std::uint64_t map_clouds = 0;
  std::uint64_t clouds_rejected = 0;     // complete but unusable (bad pose, wrong message type)
  std::uint64_t wrong_channel = 0;       // datagram type not allowed on the endpoint it came in on
  std::uint64_t shares_untrusted = 0;    // map shares the verifier refused (reasons: verifier counters)
  std::uint64_t shares_paced = 0;        // admitted shares the map did not need (source's last is recent): not verified
  std::uint64_t shares_paced_on_arrival = 0;  // shares the map would not fuse, known at their first fragment: not hashed
  std::uint64_t shares_off_background = 0;    // infrastructure shares off their unit's background: refused before ECDSA
  std::uint64_t shares_queued = 0;       // admitted shares put in the verification queue
  std::uint64_t shares_queue_dropped = 0;  // oldest waiting share dropped: queue full
  std::uint64_t signature_verifications = 0;  // ECDSA verifications run (<= kMax.. per period)
  std::uint64_t signatures_checked_on_arrival = 0;  // of those: run as the share completed (no map yet)
  std::uint64_t ego_time_rejected = 0;   // ego scans dated implausibly far from the local clock / not newer
  std::uint64_t can_repeated = 0;        // rolling counter did not advance: replayed / stuck frame, dropped
  std::uint64_t can_counter_gaps = 0;    // frames lost by the rolling counter (accepted, counted)
};

// Host instructions of the trust work the decoder does, for the period budget (callgrind, x86-64
// -O2, mbedTLS 2.28 C code; tools/bench/share_cost.cpp): SHA-256 of a fragment's payload ~131 per
// byte (168 k for a 1,280-byte fragment), one ECDSA P-256 verification 11.9 M (14 M for a key's
// first).
inline constexpr double kShareHashInstructionsPerByte = 131.0;
inline constexpr double kShareVerifyInstructions = 12e6;
// A cloud scored on its unit's surveyed background (MapFusion::fits_background; PeriodWorkParams).
inline constexpr double kShareBackgroundInstructions = 0.8e6;

class InputDecoder {
 public:
  // epoch_ns: disciplined time that maps to localizer time 0 (see localizer_time_s).
  explicit InputDecoder(std::int64_t epoch_ns = 0) : epoch_ns_(epoch_ns) {}
  void set_epoch_ns(std::int64_t epoch_ns) { epoch_ns_ = epoch_ns; }
  std::int64_t epoch_ns() const { return epoch_ns_; }

  // One CAN frame received at disciplined time time_ns.
  DecodedCan decode_can(const hal::CanFrame& frame, std::int64_t time_ns);
  // Latest GNSS time frame (valid after kGnssFix), for PPS discipline.
  const protocol::GnssTime& last_gnss_time() const { return gnss_time_; }

  // One datagram received at monotonic now_ns. True when it completed a cloud: the caller first
  // drains earlier inputs (CAN), then calls decode_completed() before the next datagram.
  // local_time_ns: the disciplined clock now (freshness of map shares and ego scans).
  bool on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns, std::int64_t local_time_ns,
                   DatagramChannel channel);
  // Emulation / offline convenience: local time = epoch + now_ns (the SimClock's relation), and
  // the channel taken from the datagram's message type (an offline event stream has no sockets).
  bool on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns);
  // The cloud the last datagram completed, as a localizer input (kNone when there is none; a
  // cloud is returned once). A map share is returned only when the verifier accepted it; its
  // source id and agent flag come from the provisioned trust list, not from the header.
  // A map share that passes the checks that need no clock is queued (kMapQueued); an ego scan
  // (kEgoScan or kEgoRejected) opens a new verification period at the local time of its completion.
  DecodedCloud decode_completed();
  // The same, with the local (disciplined) clock read again after the caller drained the CAN
  // frames received before the cloud's last fragment (the emulated clock moves with them).
  DecodedCloud decode_completed(std::int64_t local_time_ns);
  // Period boundary work: the next queued share, verified (kMapCloud or kRejected), oldest first;
  // kNone when the queue is empty or this period already ran kMaxSignatureVerificationsPerPeriod
  // verifications. Each share's generation time is judged against the local clock of the first
  // period boundary after it completed (a share refused for its time costs no verification and
  // is not returned: counted). Callers drain it when an ego scan completes, before applying the
  // scan, so verified shares reach map fusion before the scan. Points stay valid until the next
  // call of decode_completed() or next_verified_share().
  DecodedCloud next_verified_share();
  // The same, asking `wanted` (nullptr: all) whether the localizer would fuse the share before
  // its signature is verified: a share it would not (kPaced) costs no ECDSA (counted, not returned).
  DecodedCloud next_verified_share(const MapShareWanted* wanted);
  // Asked on the first fragment of every map share: a share the map would not fuse (`wanted` says
  // no for its header's sender and time) is neither hashed nor verified, and completes as
  // kMapPaced (counted). A forged header can only get its own share dropped. nullptr: every share
  // is hashed (the default).
  void set_share_filter(const MapShareWanted* wanted) { share_filter_ = wanted; }
  // Estimated instructions of the trust work (fragment hashing, ECDSA) since the last call: the
  // caller adds them to the period's budget (Localizer::add_period_work) before the ego scan.
  // An ECDSA run before the first scan is charged to the period that releases its share (the
  // charge must not depend on the order two sockets were read in; it errs towards deferring).
  double take_trust_work() {
    const double w = trust_work_;
    trust_work_ = 0.0;
    return w;
  }
  // Opens a verification period at local_time_ns (decode_completed() does this for ego scans).
  void begin_verification_period(std::int64_t local_time_ns);
  void begin_verification_period() { begin_verification_period(completed_local_time_ns_); }
  std::size_t shares_waiting() const { return schedule_.waiting(); }
  std::size_t expire(std::int64_t now_ns) {
    verifier_.expire(now_ns);
    return reassembler_.expire(now_ns);
  }

  // Provisioned trust list (start-up). Without one, every map share is refused (unknown signer).
  void provision_trust(const trust::TrustList& list) { verifier_.provision(list); }
  const trust::MapShareVerifier& verifier() const { return verifier_; }

  const DecoderCounters& counters() const { return counters_; }
  const protocol::ReassemblyCounters& reassembly_counters() const { return reassembler_.counters(); }

 private:
  static DecodedCan with_kind(CanInputKind kind);
  // CRC / DLC / range, then the rolling counter; only an accepted frame reaches `out` (counted).
  template <typename M>
  bool accept(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& out);
  DecodedCan decode_vehicle(const hal::CanFrame& frame, double t);
  template <typename M>
  DecodedCan decode_gnss_part(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& part, bool& have);
  DecodedCan decode_position(const hal::CanFrame& frame);
  DecodedCan decode_time(const hal::CanFrame& frame, double t);
  // The fix closed by the time frame, from the stored position, status, velocity and DOP frames.
  GnssInput assemble_gnss_fix(double t) const;
  bool pose_to_matrix(const protocol::SensorPose& pose, Mat4d& out) const;
  DecodedCloud queue_share(const protocol::ReassembledCloud& cloud, const Mat4d& pose, double t);
  // Rolling counters (every inbound frame carries one): a repeat is dropped, a gap counted.
  bool counter_ok(protocol::RollingCounterMonitor& monitor, std::uint8_t counter);

  std::int64_t epoch_ns_ = 0;
  CloudReassembler reassembler_{};
  std::array<Vec3f, kMaxCloudPoints> points_{};
  std::array<float, kMaxCloudPoints> point_times_{};
  bool completed_pending_ = false;
  std::int64_t completed_local_time_ns_ = 0;
  bool have_ego_time_ = false;
  std::uint64_t last_ego_stamp_ns_ = 0;
  std::uint32_t ego_frames_ = 0;  // ego frames consumed (fused or refused for their time)
  trust::MapShareVerifier verifier_{};
  // Per-fragment SHA-256 of map-share payloads as they arrived, by reassembly slot and index.
  std::array<trust::Digest, kReassemblySlots * kMaxCloudFragments> fragment_digests_{};
  const MapShareWanted* share_filter_ = nullptr;
  std::array<bool, kReassemblySlots> slot_paced_{};  // the share in this slot is not wanted: not hashed
  double trust_work_ = 0.0;                          // [instructions] since take_trust_work()
  std::size_t checked_on_arrival_ = 0;               // signatures checked on arrival this period
  struct QueuedShare {
    trust::VerificationJob job{};
    double t = 0.0;
    Mat4d world_T_sensor = Mat4d::Identity();
    std::uint32_t point_count = 0;
    bool judged = false;             // judge_time_ns is set
    std::int64_t judge_time_ns = 0;  // local clock of the first period boundary after completion
  };
  std::array<QueuedShare, kShareVerifyQueueCapacity> queue_{};
  std::array<std::array<Vec3f, kMaxCloudPoints>, kShareVerifyQueueCapacity> queue_points_{};
  ShareSchedule schedule_{};
  std::int64_t period_time_ns_ = 0;  // local clock of the latest period boundary
  protocol::RollingCounterMonitor vehicle_counter_{}, gnss_position_counter_{}, gnss_status_counter_{},
      gnss_velocity_counter_{}, gnss_dop_counter_{}, gnss_time_counter_{};

  protocol::GnssPositionPairer position_pairer_{};
  protocol::GnssStatus gnss_status_{};
  protocol::GnssVelocity gnss_velocity_{};
  protocol::GnssDop gnss_dop_{};
  protocol::GnssTime gnss_time_{};
  bool have_position_ = false;  // the pairer holds this fix's latitude + longitude
  bool have_status_ = false;
  bool have_velocity_ = false;
  bool have_dop_ = false;
  bool gnss_since_last_scan_ = false;
  DecoderCounters counters_{};
};

}  // namespace v2xloc::firmware
