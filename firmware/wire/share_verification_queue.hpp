// Map shares from completion to map fusion. As the fragments arrive: the share filter (a share the
// map would not fuse is decided on its first fragment and never hashed) and the per-fragment
// SHA-256 the signature covers. As a share completes: the cheap trust checks (signer on the
// provisioned trust list, sender, surveyed pose, not a replay), then the queue. At each period
// boundary (an ego scan): the waiting shares released oldest first on the schedule of
// share_schedule.hpp, each judged fresh by that boundary's clock, asked whether the map still wants
// it and whether an infrastructure cloud fits its unit's surveyed background, then its ECDSA check.
// The hashing and ECDSA work is accounted for the period budget. Never calls the localizer.
// Allocation-free; the queued shares' points are inside: make the object static.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/trust/map_share_verifier.hpp"
#include "firmware/wire/cloud_input_decoder.hpp"
#include "firmware/wire/share_schedule.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

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

struct ShareCounters {
  std::uint64_t map_clouds = 0;               // verified shares returned (kMapCloud)
  std::uint64_t shares_malformed = 0;         // completed outside the reassembler's slot / fragment geometry
  std::uint64_t shares_untrusted = 0;         // map shares the verifier refused (reasons: verifier counters)
  std::uint64_t shares_paced = 0;             // admitted shares the map did not need (source's last is recent): not verified
  std::uint64_t shares_paced_on_arrival = 0;  // shares the map would not fuse, known at their first fragment: not hashed
  std::uint64_t shares_off_background = 0;    // infrastructure shares off their unit's background: refused before ECDSA
  std::uint64_t shares_queued = 0;            // admitted shares put in the verification queue
  std::uint64_t shares_queue_dropped = 0;     // oldest waiting share dropped: queue full
  std::uint64_t signature_verifications = 0;  // ECDSA verifications run (<= kMax.. per period)
  std::uint64_t signatures_checked_on_arrival = 0;  // of those: run as the share completed (no map yet)
};

// Host instructions of the trust work, for the period budget (callgrind, x86-64 -O2, mbedTLS 2.28
// C code; tools/bench/share_cost.cpp): SHA-256 of a fragment's payload ~131 per byte (168 k for a
// 1,280-byte fragment), one ECDSA P-256 verification 11.9 M (14 M for a key's first).
inline constexpr double kShareHashInstructionsPerByte = 131.0;
inline constexpr double kShareVerifyInstructions = 12e6;
// A cloud scored on its unit's surveyed background (MapFusion::fits_background; PeriodWorkParams).
inline constexpr double kShareBackgroundInstructions = 0.8e6;

class ShareVerificationQueue {
 public:
  // Provisioned trust list (start-up). Without one, every map share is refused (unknown signer).
  void provision_trust(const trust::TrustList& list) { verifier_.provision(list); }
  const trust::MapShareVerifier& verifier() const { return verifier_; }
  // Asked on the first fragment of every map share: a share the map would not fuse (`wanted` says
  // no for its header's sender and time) is neither hashed nor verified, and completes as
  // kMapPaced (counted). A forged header can only get its own share dropped. nullptr: every share
  // is hashed (the default). Also asked, on completion, whether the map awaits its first map.
  void set_share_filter(const MapShareWanted* wanted) { share_filter_ = wanted; }

  // A signature datagram received on the V2X endpoint at monotonic now_ns.
  void on_signature_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns) {
    verifier_.on_signature_datagram(datagram, now_ns);
  }
  // A map-share fragment the reassembler placed; t: its header's time in localizer seconds.
  void on_share_fragment(const protocol::AcceptedFragment& fragment, double t);
  // A completed map share with its header's pose and time: the checks that need no clock, then
  // the queue (kMapQueued), or kMapPaced (the share filter said no on its first fragment) or
  // kRejected. Before the first period boundary every queued share's ECDSA runs as it completes;
  // while the share filter awaits the first map, at most kMaxSignatureVerificationsPerPeriod a period.
  DecodedCloud queue(const protocol::ReassembledCloud& cloud, const Mat4d& world_T_sensor, double t);

  // Opens a verification period at local_time_ns (an ego scan, used or refused): the per-period
  // budget starts again, and the shares waiting are judged fresh by this clock.
  void begin_period(std::int64_t local_time_ns);
  // The next queued share, verified (kMapCloud or kRejected), oldest first; kNone when the queue is
  // empty or this period already ran kMaxSignatureVerificationsPerPeriod verifications. Each share's
  // generation time is judged against the local clock of the first period boundary after it
  // completed (a share refused for its time costs no verification and is not returned: counted).
  // `wanted` (nullptr: all) is asked whether the localizer would fuse the share, and for an
  // infrastructure share whether it fits its background, before its signature is verified: one it
  // would not costs no ECDSA (counted, not returned). Callers drain it when an ego scan completes,
  // before applying the scan, so verified shares reach map fusion before the scan. Points stay
  // valid until the next call of queue() or next_verified_share().
  DecodedCloud next_verified_share(const MapShareWanted* wanted = nullptr);
  // Estimated instructions of the trust work (fragment hashing, ECDSA) since the last call: the
  // caller adds them to the period's budget (Localizer::add_period_work) before the ego scan.
  // An ECDSA run before the first scan is charged to the period that releases its share (the
  // charge must not depend on the order two sockets were read in; it errs towards deferring).
  double take_trust_work() {
    const double w = trust_work_;
    trust_work_ = 0.0;
    return w;
  }
  std::size_t shares_waiting() const { return schedule_.waiting(); }
  // Forgets signatures whose shares never completed (monotonic now_ns).
  void expire(std::int64_t now_ns) { verifier_.expire(now_ns); }

  const ShareCounters& counters() const { return counters_; }

 private:
  struct QueuedShare {
    trust::VerificationJob job{};
    double t = 0.0;
    Mat4d world_T_sensor = Mat4d::Identity();
    std::uint32_t point_count = 0;
    bool judged = false;             // judge_time_ns is set
    std::int64_t judge_time_ns = 0;  // local clock of the first period boundary after completion
    bool background_fits = false;    // scored on its unit's surveyed background by the filter and fit
  };
  // Until the localizer has a map, a queued share's ECDSA runs as it completes.
  void check_on_arrival(QueuedShare& q);
  // Releases the next share worth a signature check (fresh, wanted, on its background) into `at`;
  // the ones refused on the way are counted and give their place in the period back.
  bool release_next(const MapShareWanted* wanted, std::size_t& at);
  DecodedCloud verify(const QueuedShare& q, std::size_t at);

  trust::MapShareVerifier verifier_{};
  // Per-fragment SHA-256 of map-share payloads as they arrived, by reassembly slot and index.
  std::array<trust::Digest, kReassemblySlots * kMaxCloudFragments> fragment_digests_{};
  const MapShareWanted* share_filter_ = nullptr;
  std::array<bool, kReassemblySlots> slot_paced_{};  // the share in this slot is not wanted: not hashed
  double trust_work_ = 0.0;                          // [instructions] since take_trust_work()
  std::array<QueuedShare, kShareVerifyQueueCapacity> queue_{};
  std::array<std::array<Vec3f, kMaxCloudPoints>, kShareVerifyQueueCapacity> queue_points_{};
  ShareSchedule schedule_{};
  bool period_begun_ = false;          // a period boundary came: before it, every share is checked on arrival
  std::int64_t period_time_ns_ = 0;    // local clock of the latest period boundary
  std::size_t checked_on_arrival_ = 0;  // signatures checked on arrival this period
  ShareCounters counters_{};
};

}  // namespace v2xloc::firmware
