#include "firmware/trust/map_share_verifier.hpp"

#include <cmath>

#include "firmware/trust/cloud_digest.hpp"

namespace v2xloc::trust {

const char* to_string(ShareVerdict v) {
  switch (v) {
    case ShareVerdict::kAccepted: return "accepted";
    case ShareVerdict::kMissingSignature: return "missing signature";
    case ShareVerdict::kUnknownSigner: return "unknown signer";
    case ShareVerdict::kSenderMismatch: return "sender id mismatch";
    case ShareVerdict::kTooOld: return "too old";
    case ShareVerdict::kFuture: return "from the future";
    case ShareVerdict::kStampSkew: return "time stamp far from generation time";
    case ShareVerdict::kReplay: return "replay";
    case ShareVerdict::kPoseMismatch: return "declared pose off the surveyed pose";
    case ShareVerdict::kBadSignature: return "bad signature";
    case ShareVerdict::kCryptoError: return "crypto error";
  }
  return "?";
}

bool matches_survey(const SurveyedPose& survey, const protocol::SensorPose& declared,
                    const MapShareVerifierConfig& config) {
  double d2 = 0.0, dot = 0.0, norm2 = 0.0, survey_norm2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double d = declared.position_m[i] - survey.position_m[i];
    d2 += d * d;
  }
  for (int i = 0; i < 4; ++i) {
    dot += declared.quaternion_xyzw[i] * survey.quaternion_xyzw[i];
    norm2 += declared.quaternion_xyzw[i] * declared.quaternion_xyzw[i];
    survey_norm2 += survey.quaternion_xyzw[i] * survey.quaternion_xyzw[i];
  }
  const double tol = config.survey_position_tolerance_m;
  if (!(d2 <= tol * tol) || !(norm2 > 0.0) || !std::isfinite(norm2)) return false;  // NaN compares false
  // Rotation angle between the two: 2 acos(|<q1, q2>|) with both normalized (q and -q are the same
  // rotation). The parser admits a survey off unit length by its tolerance (a surveyor's rotation
  // matrix is orthonormal to ~1e-7, not exactly), more than the 0.05 deg test resolves unnormalized.
  const double cos_half = std::fabs(dot) / std::sqrt(norm2 * survey_norm2);
  return cos_half >= std::cos(0.5 * config.survey_angle_tolerance_rad);
}

void MapShareVerifier::provision(const TrustList& list) {
  list_ = list;
  last_generation_ns_ = {};
  has_last_ = {};
  pending_ = {};
}

protocol::SignatureParseStatus MapShareVerifier::on_signature_datagram(std::span<const std::uint8_t> datagram,
                                                                       std::int64_t now_ns) {
  protocol::CloudSignature sig;
  const protocol::SignatureParseStatus s = protocol::parse_signature_datagram(datagram, sig);
  if (s != protocol::SignatureParseStatus::kOk) {
    ++counters_.signatures_malformed;
    return s;
  }
  ++counters_.signatures_rx;
  // Same cloud again (duplicate datagram or a second signature for it): the newest one counts.
  Pending* slot = nullptr;
  for (Pending& p : pending_) {
    if (p.used && p.sig.sender_id == sig.sender_id && p.sig.sensor_id == sig.sensor_id &&
        p.sig.frame_seq == sig.frame_seq) {
      slot = &p;
      break;
    }
  }
  if (slot == nullptr) {
    for (Pending& p : pending_) {
      if (!p.used) {
        slot = &p;
        break;
      }
    }
  }
  if (slot == nullptr) {  // full: the oldest pending signature gives way
    slot = &pending_[0];
    for (Pending& p : pending_) {
      if (p.rx_ns < slot->rx_ns) slot = &p;
    }
    ++counters_.signatures_evicted;
  }
  *slot = Pending{sig, now_ns, true};
  return s;
}

void MapShareVerifier::expire(std::int64_t now_ns) {
  for (Pending& p : pending_) {
    if (p.used && now_ns - p.rx_ns > config_.pending_timeout_ns) {
      p.used = false;
      ++counters_.signatures_expired;
    }
  }
}

ShareVerifyResult MapShareVerifier::reject(ShareVerdict v, const TrustedSigner* signer) {
  switch (v) {
    case ShareVerdict::kMissingSignature: ++counters_.missing_signature; break;
    case ShareVerdict::kUnknownSigner: ++counters_.unknown_signer; break;
    case ShareVerdict::kSenderMismatch: ++counters_.sender_mismatch; break;
    case ShareVerdict::kTooOld: ++counters_.too_old; break;
    case ShareVerdict::kFuture: ++counters_.future; break;
    case ShareVerdict::kStampSkew: ++counters_.stamp_skew; break;
    case ShareVerdict::kReplay: ++counters_.replay; break;
    case ShareVerdict::kPoseMismatch: ++counters_.pose_mismatch; break;
    case ShareVerdict::kBadSignature: ++counters_.bad_signature; break;
    case ShareVerdict::kCryptoError: ++counters_.crypto_error; break;
    case ShareVerdict::kAccepted: break;
  }
  return ShareVerifyResult{v, signer};
}

ShareVerifyResult MapShareVerifier::admit(const protocol::CloudFrameInfo& info, const Digest& digest,
                                          VerificationJob& job) {
  Pending* pending = nullptr;
  for (Pending& p : pending_) {
    if (p.used && p.sig.sender_id == info.sender_id && p.sig.sensor_id == info.sensor_id &&
        p.sig.frame_seq == info.frame_seq) {
      pending = &p;
      break;
    }
  }
  if (pending == nullptr) return reject(ShareVerdict::kMissingSignature);
  const protocol::CloudSignature sig = pending->sig;
  pending->used = false;  // one verification per signature, whatever the outcome

  const TrustedSigner* signer = list_.find(sig.signer);
  if (signer == nullptr) return reject(ShareVerdict::kUnknownSigner);
  if (signer->sender_id != info.sender_id) return reject(ShareVerdict::kSenderMismatch, signer);
  if (signer->surveyed && !matches_survey(signer->survey, info.pose, config_)) {
    return reject(ShareVerdict::kPoseMismatch, signer);
  }
  // Unsigned wire times compared in signed form (both are Unix ns < 2^63; larger: refused).
  const auto gen = static_cast<std::int64_t>(sig.generation_time_ns & 0x7FFFFFFFFFFFFFFFull);
  const auto stamp = static_cast<std::int64_t>(info.timestamp_ns & 0x7FFFFFFFFFFFFFFFull);
  if (sig.generation_time_ns > 0x7FFFFFFFFFFFFFFFull) return reject(ShareVerdict::kFuture, signer);
  if (info.timestamp_ns > 0x7FFFFFFFFFFFFFFFull || stamp > gen + config_.max_future_ns ||
      stamp < gen - config_.max_stamp_skew_ns) {
    return reject(ShareVerdict::kStampSkew, signer);
  }
  const std::size_t index = static_cast<std::size_t>(signer - list_.signers.data());
  if (has_last_[index] && sig.generation_time_ns <= last_generation_ns_[index]) {
    return reject(ShareVerdict::kReplay, signer);
  }
  job.sig = sig;
  job.signer_index = index;
  job.to_verify = signed_digest(sig, digest);
  return ShareVerifyResult{ShareVerdict::kAccepted, signer};
}

ShareVerifyResult MapShareVerifier::check_time(const VerificationJob& job, std::int64_t local_time_ns) {
  const TrustedSigner* signer = job.signer_index < list_.count ? &list_.signers[job.signer_index] : nullptr;
  const auto gen = static_cast<std::int64_t>(job.sig.generation_time_ns & 0x7FFFFFFFFFFFFFFFull);
  if (job.sig.generation_time_ns > 0x7FFFFFFFFFFFFFFFull || gen > local_time_ns + config_.max_future_ns) {
    return reject(ShareVerdict::kFuture, signer);
  }
  if (gen < local_time_ns - config_.max_age_ns) return reject(ShareVerdict::kTooOld, signer);
  return ShareVerifyResult{ShareVerdict::kAccepted, signer};
}

bool MapShareVerifier::check_signature(VerificationJob& job) {
  if (job.signer_index >= list_.count) return false;
  job.signature = verify_digest(list_.signers[job.signer_index].key, job.to_verify, job.sig.signature);
  job.signature_checked = true;
  return true;
}

ShareVerifyResult MapShareVerifier::complete(const VerificationJob& job) {
  if (job.signer_index >= list_.count) return reject(ShareVerdict::kUnknownSigner);  // re-provisioned since
  const TrustedSigner* signer = &list_.signers[job.signer_index];
  if (has_last_[job.signer_index] && job.sig.generation_time_ns <= last_generation_ns_[job.signer_index]) {
    return reject(ShareVerdict::kReplay, signer);
  }
  const CryptoStatus c =
      job.signature_checked ? job.signature : verify_digest(signer->key, job.to_verify, job.sig.signature);
  if (c == CryptoStatus::kBadSignature || c == CryptoStatus::kBadKey) return reject(ShareVerdict::kBadSignature, signer);
  if (c != CryptoStatus::kOk) return reject(ShareVerdict::kCryptoError, signer);
  last_generation_ns_[job.signer_index] = job.sig.generation_time_ns;
  has_last_[job.signer_index] = true;
  ++counters_.accepted;
  return ShareVerifyResult{ShareVerdict::kAccepted, signer};
}

ShareVerifyResult MapShareVerifier::verify(const protocol::CloudFrameInfo& info, const Digest& digest,
                                           std::int64_t local_time_ns) {
  VerificationJob job;
  const ShareVerifyResult admitted = admit(info, digest, job);
  if (admitted.verdict != ShareVerdict::kAccepted) return admitted;
  const ShareVerifyResult fresh = check_time(job, local_time_ns);
  if (fresh.verdict != ShareVerdict::kAccepted) return fresh;
  return complete(job);
}

}  // namespace v2xloc::trust
