// Gatekeeper between the V2X channel and the map: a reassembled map share reaches map fusion only
// when its signature datagram arrived, names a provisioned signer whose sender id matches the
// cloud, the generation time is fresh by the LOCAL disciplined clock, it is newer than anything
// accepted from that signer (replay), and the ECDSA P-256 signature over the whole cloud's digest
// verifies. Every rejection is counted by reason (the firmware reports them on CAN).
//
// Freshness window: max_age 1.0 s. Map fusion ages sources out after 2 s (map_fusion.hpp), the
// infrastructure re-sends every 100 ms, and a V2X hop plus reassembly takes tens of ms; 1 s
// admits a share delayed by ten periods (the fault matrix delays by 0.5 s) while a recorded share
// replayed later than that is refused without touching the crypto. Future: 40 ms (clocks
// disciplined by GNSS agree to well under a millisecond; 40 ms is the ETSI/1609.2 style margin the
// brief fixes). Replay: per signer, the generation time must strictly increase (a signer signs at
// most one cloud per sensor per instant; a duplicated or re-sent cloud is a replay).
//
// Surveyed pose: an infrastructure unit is a fixed installation whose sensor pose the trust list
// carries (trust_list.hpp `survey`). A share whose declared pose (header world_T_sensor) is off
// that survey by more than 2 cm or 0.05 deg is refused (kPoseMismatch), signed or not: a signed
// unit that lies about where it stands would otherwise place its whole cloud wrong, and map fusion
// can only outvote it where other units overlap. Both numbers come from the same survey (the unit
// declares the pose it was provisioned with; the simulator's are bit-identical), so any difference
// is a fault or an attack; the tolerances only admit a re-surveyed unit's rounding and stay well
// below the fused-error target (0.02 m): 0.05 deg moves a point 35 m away by 3 cm, less than the
// map's 0.2 m voxel. An infrastructure signer without a survey keeps today's behaviour.
//
// Checks run cheapest first; the ECDSA verification (the only expensive step) runs last, so
// garbage, unknown signers, stale and replayed shares cost no crypto. Three steps, so the caller can
// spread the ECDSA work over periods: admit() runs the checks that need no clock when the cloud
// completes (signature present, signer, sender id, stamp vs generation time, replay) and returns a
// VerificationJob; check_time() judges the generation time against the local clock of the period
// boundary that first follows the completion (a deterministic instant: the clock of the ego scan
// that closes the period, whichever socket a datagram happened to be read from first), so a share
// verified a period later is judged as fairly as one verified at once; complete() runs the replay
// check again and the ECDSA verification. verify() does all three at once. Allocation-free.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/trust/trust_list.hpp"

namespace v2xloc::trust {

struct MapShareVerifierConfig {
  std::int64_t max_age_ns = 1'000'000'000;      // [ns] generation time older than now - this: too old
  std::int64_t max_future_ns = 40'000'000;      // [ns] generation time later than now + this: future
  std::int64_t max_stamp_skew_ns = 1'000'000'000;  // [ns] |cloud time stamp - generation time| allowed
  std::int64_t pending_timeout_ns = 1'000'000'000; // [ns] a signature waits this long for its cloud
  double survey_position_tolerance_m = 0.02;        // [m] declared vs surveyed sensor position
  double survey_angle_tolerance_rad = 0.05 * 3.14159265358979323846 / 180.0;  // [rad] orientation
};

enum class ShareVerdict : std::uint8_t {
  kAccepted,
  kMissingSignature,  // no signature datagram for this cloud (unsigned, lost or late)
  kUnknownSigner,     // HashedId8 not in the trust list
  kSenderMismatch,    // cloud's sender id is not the signer's provisioned id
  kTooOld,            // generation time older than max_age by the local clock
  kFuture,            // generation time more than max_future ahead of the local clock
  kStampSkew,         // the cloud's own time stamp far from its generation time
  kReplay,            // not newer than the last share accepted from this signer
  kPoseMismatch,      // infrastructure: declared sensor pose off the surveyed one
  kBadSignature,
  kCryptoError,       // arena exhausted or mbedTLS error (fail closed)
};
const char* to_string(ShareVerdict v);

// True when `declared` is within the tolerances of `survey` (a non-finite or zero quaternion: false).
bool matches_survey(const SurveyedPose& survey, const protocol::SensorPose& declared,
                    const MapShareVerifierConfig& config);

struct ShareVerifyResult {
  ShareVerdict verdict = ShareVerdict::kMissingSignature;
  const TrustedSigner* signer = nullptr;  // provisioned signer (set from kSenderMismatch on)
};

// A share that passed every cheap check and waits for its ECDSA verification.
struct VerificationJob {
  protocol::CloudSignature sig{};
  std::size_t signer_index = 0;  // into the trust list
  Digest to_verify{};            // signed_digest(sig, cloud digest)
  bool signature_checked = false;              // check_signature() ran: complete() uses its result
  CryptoStatus signature = CryptoStatus::kOk;  // that result
};

struct VerifierCounters {
  std::uint64_t signatures_rx = 0;
  std::uint64_t signatures_malformed = 0;
  std::uint64_t signatures_evicted = 0;   // pending table full: oldest dropped
  std::uint64_t signatures_expired = 0;   // no cloud within pending_timeout
  std::uint64_t accepted = 0;
  std::uint64_t missing_signature = 0;
  std::uint64_t unknown_signer = 0;
  std::uint64_t sender_mismatch = 0;
  std::uint64_t too_old = 0;
  std::uint64_t future = 0;
  std::uint64_t stamp_skew = 0;
  std::uint64_t replay = 0;
  std::uint64_t pose_mismatch = 0;  // infrastructure share declaring a pose off its survey
  std::uint64_t bad_signature = 0;
  std::uint64_t crypto_error = 0;
  std::uint64_t rejected() const {
    return missing_signature + unknown_signer + sender_mismatch + too_old + future + stamp_skew + replay +
           pose_mismatch + bad_signature + crypto_error;
  }
};

class MapShareVerifier {
 public:
  static constexpr std::size_t kPendingSignatures = 16;

  explicit MapShareVerifier(const MapShareVerifierConfig& config = {}) : config_(config) {}
  void provision(const TrustList& list);
  const TrustList& trust_list() const { return list_; }
  bool provisioned() const { return list_.count > 0; }

  // A datagram carrying the signature magic, received at monotonic now_ns.
  protocol::SignatureParseStatus on_signature_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns);
  // A completed map share whose cloud digest (cloud_digest.hpp, over the wire bytes) is `digest`.
  // kAccepted here means "admitted": `job` is ready for check_time() and complete().
  ShareVerifyResult admit(const protocol::CloudFrameInfo& info, const Digest& digest, VerificationJob& job);
  // Generation time against the local (disciplined) clock: kTooOld, kFuture or kAccepted.
  ShareVerifyResult check_time(const VerificationJob& job, std::int64_t local_time_ns);
  // The ECDSA verification alone, ahead of complete() (it depends on nothing but the job): lets the
  // caller run it when it has time; complete() then uses the stored result. Counted as a
  // verification when it runs. False: job names no provisioned signer (nothing was checked).
  bool check_signature(VerificationJob& job);
  // Replay check (again: an earlier job may have advanced the signer) and the ECDSA verification
  // (unless check_signature() already ran it).
  ShareVerifyResult complete(const VerificationJob& job);
  ShareVerifyResult verify(const protocol::CloudFrameInfo& info, const Digest& digest, std::int64_t local_time_ns);
  void expire(std::int64_t now_ns);

  const VerifierCounters& counters() const { return counters_; }

 private:
  struct Pending {
    protocol::CloudSignature sig{};
    std::int64_t rx_ns = 0;
    bool used = false;
  };
  ShareVerifyResult reject(ShareVerdict v, const TrustedSigner* signer = nullptr);

  MapShareVerifierConfig config_;
  TrustList list_{};
  std::array<std::uint64_t, kMaxTrustedSigners> last_generation_ns_{};
  std::array<bool, kMaxTrustedSigners> has_last_{};
  std::array<Pending, kPendingSignatures> pending_{};
  VerifierCounters counters_{};
};

}  // namespace v2xloc::trust
