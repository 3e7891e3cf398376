#include "firmware/wire/share_verification_queue.hpp"

#include "firmware/trust/cloud_digest.hpp"

namespace v2xloc::firmware {
namespace {

DecodedCloud with_kind(CloudKind kind) {
  DecodedCloud out;
  out.kind = kind;
  return out;
}

}  // namespace

void ShareVerificationQueue::on_share_fragment(const protocol::AcceptedFragment& fragment, double t) {
  if (fragment.slot >= kReassemblySlots || fragment.fragment_index >= kMaxCloudFragments) return;
  // A share the map would not fuse is decided on its first fragment and costs no hashing. The
  // map's answer turns from "no" to "yes" only when the source's stored cloud expires (3 s after
  // a cloud at most 1.9 s older than this one) or is outvoted, rarely while a share waits.
  if (fragment.opened_frame) {
    slot_paced_[fragment.slot] = share_filter_ != nullptr && !share_filter_->wants(fragment.sender_id, t);
  }
  if (slot_paced_[fragment.slot]) return;
  // Hash what arrived, once per fragment (the share's signature covers these digests).
  fragment_digests_[fragment.slot * kMaxCloudFragments + fragment.fragment_index] =
      trust::fragment_digest(fragment.payload);
  trust_work_ += kShareHashInstructionsPerByte * static_cast<double>(fragment.payload.size());
}

// Trust before fusion: a signature over the whole cloud's wire bytes by a provisioned signer, not a
// replay. Freshness (judged at the period boundary) and the ECDSA check wait in the queue for the
// period's budget. Role and source id come from the trust list, not the header.
DecodedCloud ShareVerificationQueue::queue(const protocol::ReassembledCloud& cloud, const Mat4d& world_T_sensor,
                                           double t) {
  if (cloud.slot >= kReassemblySlots || cloud.fragment_count > kMaxCloudFragments ||
      cloud.point_count > kMaxCloudPoints || cloud.xyz.size() < 3u * cloud.point_count) {
    ++counters_.shares_malformed;
    return with_kind(CloudKind::kRejected);
  }
  if (slot_paced_[cloud.slot]) {
    ++counters_.shares_paced_on_arrival;
    return with_kind(CloudKind::kMapPaced);
  }
  const std::span<const trust::Digest> fragments(&fragment_digests_[cloud.slot * kMaxCloudFragments],
                                                 cloud.fragment_count);
  trust::VerificationJob job;
  const trust::ShareVerifyResult verdict = verifier_.admit(cloud.info, trust::cloud_digest(cloud, fragments), job);
  if (verdict.verdict != trust::ShareVerdict::kAccepted) {
    ++counters_.shares_untrusted;
    return with_kind(CloudKind::kRejected);
  }
  const ShareSchedule::Admission admission = schedule_.admit();  // full: the oldest gives way
  if (admission.dropped_oldest) ++counters_.shares_queue_dropped;
  const std::size_t at = admission.slot;
  QueuedShare& q = queue_[at];
  q.job = job;
  q.t = t;
  q.world_T_sensor = world_T_sensor;
  q.point_count = cloud.point_count;
  q.judged = false;
  q.background_fits = false;
  copy_cloud_points(cloud, std::span<Vec3f>(queue_points_[at].data(), cloud.point_count));
  ++counters_.shares_queued;
  check_on_arrival(q);
  return with_kind(CloudKind::kMapQueued);
}

// Until the localizer has a map, a share's ECDSA runs as it completes, at most
// kMaxSignatureVerificationsPerPeriod a period (before the first period boundary: every queued
// share), instead of in the period that fuses it, which also builds the first map. Its verdict is
// used at the period boundary as every other share's, so only where the work falls changes, not
// the outcome.
void ShareVerificationQueue::check_on_arrival(QueuedShare& q) {
  const bool no_map = share_filter_ != nullptr && share_filter_->awaiting_first_map();
  if ((!period_begun_ || (no_map && checked_on_arrival_ < kMaxSignatureVerificationsPerPeriod)) &&
      verifier_.check_signature(q.job)) {
    ++checked_on_arrival_;
    ++counters_.signature_verifications;
    ++counters_.signatures_checked_on_arrival;
  }
}

void ShareVerificationQueue::begin_period(std::int64_t local_time_ns) {
  schedule_.begin_period();
  period_begun_ = true;
  checked_on_arrival_ = 0;
  period_time_ns_ = local_time_ns;
  for (std::size_t i = 0; i < schedule_.waiting(); ++i) {
    QueuedShare& q = queue_[schedule_.waiting_slot(i)];
    if (!q.judged) {
      q.judged = true;
      q.judge_time_ns = local_time_ns;
    }
  }
}

bool ShareVerificationQueue::release_next(const MapShareWanted* wanted, std::size_t& at) {
  for (std::size_t k = 0; k < kShareVerifyQueueCapacity; ++k) {
    if (!schedule_.release(at)) return false;
    QueuedShare& q = queue_[at];
    if (!q.judged) {  // completed after this period's boundary was opened: judged by that boundary
      q.judged = true;
      q.judge_time_ns = period_time_ns_;
    }
    const bool timely = verifier_.check_time(q.job, q.judge_time_ns).verdict == trust::ShareVerdict::kAccepted;
    const trust::TrustList& list = verifier_.trust_list();
    // Unknown signer: complete() refuses it.
    const trust::TrustedSigner* signer = q.job.signer_index < list.count ? &list.signers[q.job.signer_index] : nullptr;
    bool worth = timely && (wanted == nullptr || signer == nullptr || wanted->wants(signer->sender_id, q.t));
    std::uint64_t* refused = timely ? &counters_.shares_paced : &counters_.shares_untrusted;
    // An infrastructure cloud off its unit's surveyed background would be refused by map fusion
    // anyway: refused here, it does not take one of the period's signature checks (the scoring,
    // 0.8-2.7 M, is a fifteenth to a fifth of one; a cloud that passes carries the verdict to map
    // fusion, which does not score it again).
    if (worth && wanted != nullptr && signer != nullptr && signer->role == trust::SignerRole::kInfrastructure) {
      q.background_fits = wanted->fits_background(signer->sender_id, q.world_T_sensor,
                                                  std::span<const Vec3f>(queue_points_[at].data(), q.point_count));
      if (!q.background_fits) {
        worth = false;
        refused = &counters_.shares_off_background;
      }
    }
    if (worth) return true;
    ++*refused;
    schedule_.refund();  // no ECDSA was spent on it
  }
  return false;
}

DecodedCloud ShareVerificationQueue::next_verified_share(const MapShareWanted* wanted) {
  std::size_t at = 0;
  if (!release_next(wanted, at)) return with_kind(CloudKind::kNone);
  return verify(queue_[at], at);
}

DecodedCloud ShareVerificationQueue::verify(const QueuedShare& q, std::size_t at) {
  if (!q.job.signature_checked) ++counters_.signature_verifications;
  // Charged to the period budget even when it ran before the first scan: which shares completed
  // before it depends on which socket was read first, the budget must not.
  trust_work_ += kShareVerifyInstructions;
  const trust::ShareVerifyResult verdict = verifier_.complete(q.job);
  if (verdict.verdict != trust::ShareVerdict::kAccepted) {
    ++counters_.shares_untrusted;
    return with_kind(CloudKind::kRejected);
  }
  DecodedCloud out = with_kind(CloudKind::kMapCloud);
  MapCloudInput& in = out.map;
  in.source_id = verdict.signer->sender_id;
  in.is_agent = verdict.signer->role == trust::SignerRole::kAgent;
  in.t = q.t;
  in.world_T_sensor = q.world_T_sensor;
  in.points = std::span<const Vec3f>(queue_points_[at].data(), q.point_count);
  // The filter scored these very points at this pose for the job's signer, the one the verifier
  // accepted: map fusion does not score them again.
  in.background_fits = q.background_fits;
  ++counters_.map_clouds;
  return out;
}

}  // namespace v2xloc::firmware
