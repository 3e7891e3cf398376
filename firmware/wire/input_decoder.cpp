#include "firmware/wire/input_decoder.hpp"

#include <cmath>

#include "firmware/trust/cloud_digest.hpp"
#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware {

bool InputDecoder::counter_ok(protocol::RollingCounterMonitor& monitor, std::uint8_t counter) {
  const std::uint32_t repeated = monitor.repeated(), lost = monitor.lost();
  monitor.update(counter);
  counters_.can_counter_gaps += monitor.lost() - lost;
  if (monitor.repeated() != repeated) {
    ++counters_.can_repeated;
    return false;
  }
  return true;
}

DecodedCan InputDecoder::decode_can(const hal::CanFrame& frame, std::int64_t time_ns) {
  ++counters_.can_frames;
  const double t = localizer_time_s(time_ns, epoch_ns_);
  switch (frame.id) {
    case protocol::kVehicleMotionId: return decode_vehicle(frame, t);
    case protocol::kGnssPositionId: return decode_position(frame);
    case protocol::kGnssStatusId: return decode_gnss_part(frame, gnss_status_counter_, gnss_status_, have_status_);
    case protocol::kGnssVelocityId:
      return decode_gnss_part(frame, gnss_velocity_counter_, gnss_velocity_, have_velocity_);
    case protocol::kGnssDopId: return decode_gnss_part(frame, gnss_dop_counter_, gnss_dop_, have_dop_);
    case protocol::kGnssTimeId: return decode_time(frame, t);
    default:
      ++counters_.can_unknown_id;
      return with_kind(CanInputKind::kUnknownId);
  }
}

DecodedCan InputDecoder::with_kind(CanInputKind kind) {
  DecodedCan out;
  out.kind = kind;
  return out;
}

// Unpacks into a scratch copy, so a frame refused for its range or counter leaves the stored part.
template <typename M>
bool InputDecoder::accept(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& out) {
  M m;
  if (protocol::unpack(frame, m) != protocol::DecodeStatus::kOk) {
    ++counters_.can_rejected;
    return false;
  }
  if (!counter_ok(monitor, m.counter)) return false;
  out = m;
  return true;
}

DecodedCan InputDecoder::decode_vehicle(const hal::CanFrame& frame, double t) {
  protocol::VehicleMotion m;
  if (!accept(frame, vehicle_counter_, m)) return with_kind(CanInputKind::kRejected);
  if (!m.speed_valid || !m.yaw_rate_valid) {
    ++counters_.vehicle_invalid;
    return with_kind(CanInputKind::kInvalid);
  }
  DecodedCan out = with_kind(CanInputKind::kVehicle);
  out.vehicle = VehicleInput{t, m.wheel_speed_mps, m.yaw_rate_rps};
  ++counters_.vehicle_inputs;
  return out;
}

template <typename M>
DecodedCan InputDecoder::decode_gnss_part(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& part,
                                          bool& have) {
  if (!accept(frame, monitor, part)) return with_kind(CanInputKind::kRejected);
  have = true;
  return with_kind(CanInputKind::kGnssPart);
}

// One half of the fix's position (0x130). A latitude starts a new position: whatever pair came
// before belongs to another fix. A half that pairs with nothing leaves the fix without a position.
DecodedCan InputDecoder::decode_position(const hal::CanFrame& frame) {
  protocol::GnssPosition half;
  if (!accept(frame, gnss_position_counter_, half)) return with_kind(CanInputKind::kRejected);
  const std::uint32_t dropped = position_pairer_.dropped();
  const protocol::GnssPositionPairer::Result r = position_pairer_.push(half);
  counters_.gnss_position_dropped += position_pairer_.dropped() - dropped;
  have_position_ = r == protocol::GnssPositionPairer::Result::kPaired;
  if (r == protocol::GnssPositionPairer::Result::kDropped) return with_kind(CanInputKind::kInvalid);
  return with_kind(CanInputKind::kGnssPart);
}

// The time frame closes a fix (sent last). A fix without its status frame is incomplete; without a
// position it is forwarded as invalid (no fix); without DOP its hdop stays unknown (GnssInput's).
DecodedCan InputDecoder::decode_time(const hal::CanFrame& frame, double t) {
  if (!accept(frame, gnss_time_counter_, gnss_time_)) return with_kind(CanInputKind::kRejected);
  const std::uint32_t dropped = position_pairer_.dropped();
  position_pairer_.end_fix();
  counters_.gnss_position_dropped += position_pairer_.dropped() - dropped;
  DecodedCan out = with_kind(CanInputKind::kInvalid);
  if (!have_status_) {
    ++counters_.gnss_incomplete;
  } else {
    out = with_kind(CanInputKind::kGnssFix);
    out.gnss = assemble_gnss_fix(t);
    ++counters_.gnss_inputs;
    gnss_since_last_scan_ = true;
  }
  have_position_ = have_status_ = have_velocity_ = have_dop_ = false;
  return out;
}

GnssInput InputDecoder::assemble_gnss_fix(double t) const {
  GnssInput g;
  g.t = t;
  const bool fixed = gnss_status_.fix_type == protocol::GnssFixType::kFix2D ||
                     gnss_status_.fix_type == protocol::GnssFixType::kFix3D;
  g.valid = fixed && have_position_;
  if (have_position_) {
    g.lat_deg = position_pairer_.lat_deg();
    g.lon_deg = position_pairer_.lon_deg();
  }
  g.alt_m = gnss_status_.alt_m;
  g.h_acc = gnss_status_.h_acc_m;
  g.v_acc = gnss_status_.v_acc_m;
  g.num_sats = gnss_status_.num_sats;
  if (have_dop_) g.hdop = gnss_dop_.hdop;
  if (have_velocity_ && gnss_velocity_.valid) {
    g.velocity_valid = true;
    g.vel_east = gnss_velocity_.vel_east_mps;
    g.vel_north = gnss_velocity_.vel_north_mps;
    g.speed_acc = gnss_velocity_.speed_acc_mps;
  }
  return g;
}

bool InputDecoder::on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns) {
  const bool ego = datagram.size() > 5 && !protocol::is_signature_datagram(datagram) &&
                   datagram[5] == static_cast<std::uint8_t>(protocol::CloudMessageType::kEgoScan);
  return on_datagram(datagram, now_ns, epoch_ns_ + now_ns, ego ? DatagramChannel::kEgo : DatagramChannel::kV2x);
}

bool InputDecoder::on_datagram(std::span<const std::uint8_t> datagram, std::int64_t now_ns, std::int64_t local_time_ns,
                               DatagramChannel channel) {
  ++counters_.datagrams;
  completed_pending_ = false;
  if (protocol::is_signature_datagram(datagram)) {
    if (channel != DatagramChannel::kV2x) {
      ++counters_.wrong_channel;
      return false;
    }
    verifier_.on_signature_datagram(datagram, now_ns);
    return false;
  }
  // Message type (byte 5 of the cloud header; the CRC is checked by the reassembler): an ego scan
  // only on the ego endpoint, a map share only on the V2X one.
  if (datagram.size() > 5) {
    const bool is_ego = datagram[5] == static_cast<std::uint8_t>(protocol::CloudMessageType::kEgoScan);
    if (is_ego != (channel == DatagramChannel::kEgo)) {
      ++counters_.wrong_channel;
      return false;
    }
  }
  completed_local_time_ns_ = local_time_ns;
  const protocol::CloudStatus s = reassembler_.push(datagram, now_ns);
  const protocol::AcceptedFragment& accepted = reassembler_.last_accepted();
  if (accepted.valid && accepted.type == protocol::CloudMessageType::kMapShare &&
      accepted.slot < kReassemblySlots && accepted.fragment_index < kMaxCloudFragments) {
    // A share the map would not fuse is decided on its first fragment and costs no hashing. The
    // map's answer turns from "no" to "yes" only when the source's stored cloud expires (3 s after
    // a cloud at most 1.9 s older than this one) or is outvoted, rarely while a share waits.
    if (accepted.opened_frame) {
      slot_paced_[accepted.slot] =
          share_filter_ != nullptr &&
          !share_filter_->wants(accepted.sender_id,
                                localizer_time_s(static_cast<std::int64_t>(accepted.timestamp_ns), epoch_ns_));
    }
    if (!slot_paced_[accepted.slot]) {
      // Hash what arrived, once per fragment (the share's signature covers these digests).
      fragment_digests_[accepted.slot * kMaxCloudFragments + accepted.fragment_index] =
          trust::fragment_digest(accepted.payload);
      trust_work_ += kShareHashInstructionsPerByte * static_cast<double>(accepted.payload.size());
    }
  }
  switch (s) {
    case protocol::CloudStatus::kFrameComplete:
      completed_pending_ = true;
      return true;
    case protocol::CloudStatus::kOk:
    case protocol::CloudStatus::kDuplicate:   // normal on UDP: counted by the reassembler
    case protocol::CloudStatus::kStaleFrame:
      return false;
    default:
      ++counters_.datagrams_rejected;
      return false;
  }
}

bool InputDecoder::pose_to_matrix(const protocol::SensorPose& pose, Mat4d& out) const {
  const double* q = pose.quaternion_xyzw;
  const double norm_sq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(std::abs(norm_sq - 1.0) < 1e-3)) return false;  // also rejects NaN
  for (const double p : pose.position_m) {
    if (!std::isfinite(p)) return false;
  }
  Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
  quat.normalize();
  out = Mat4d::Identity();
  out.topLeftCorner<3, 3>() = quat.toRotationMatrix();
  out(0, 3) = pose.position_m[0];
  out(1, 3) = pose.position_m[1];
  out(2, 3) = pose.position_m[2];
  return true;
}

DecodedCloud InputDecoder::decode_completed(std::int64_t local_time_ns) {
  completed_local_time_ns_ = local_time_ns;
  return decode_completed();
}

void InputDecoder::begin_verification_period(std::int64_t local_time_ns) {
  schedule_.begin_period();
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

// A completed map share: trust checks that need no clock, then the verification queue.
DecodedCloud InputDecoder::queue_share(const protocol::ReassembledCloud& cloud, const Mat4d& pose, double t) {
  DecodedCloud out;
  const auto kind = [&out](CloudKind k) {
    out.kind = k;
    return out;
  };
  const protocol::CloudFrameInfo& info = cloud.info;
  const std::uint32_t n = cloud.point_count;
  // Trust before fusion: a signature over the whole cloud's wire bytes by a provisioned signer,
  // not a replay. Freshness (judged at the period boundary) and the ECDSA check wait in the
  // queue for the period's budget. Role and source id come from the trust list, not the header.
  if (cloud.slot >= kReassemblySlots || cloud.fragment_count > kMaxCloudFragments) {
    ++counters_.clouds_rejected;
    return kind(CloudKind::kRejected);
  }
  if (slot_paced_[cloud.slot]) {
    ++counters_.shares_paced_on_arrival;
    return kind(CloudKind::kMapPaced);
  }
  const std::span<const trust::Digest> fragments(&fragment_digests_[cloud.slot * kMaxCloudFragments],
                                                 cloud.fragment_count);
  trust::VerificationJob job;
  const trust::ShareVerifyResult verdict = verifier_.admit(info, trust::cloud_digest(cloud, fragments), job);
  if (verdict.verdict != trust::ShareVerdict::kAccepted) {
    ++counters_.shares_untrusted;
    return kind(CloudKind::kRejected);
  }
  const ShareSchedule::Admission admission = schedule_.admit();  // full: the oldest gives way
  if (admission.dropped_oldest) ++counters_.shares_queue_dropped;
  const std::size_t at = admission.slot;
  QueuedShare& q = queue_[at];
  q.job = job;
  q.t = t;
  q.world_T_sensor = pose;
  q.point_count = n;
  q.judged = false;
  for (std::uint32_t i = 0; i < n; ++i) {
    queue_points_[at][i] = Vec3f(cloud.xyz[3u * i], cloud.xyz[3u * i + 1], cloud.xyz[3u * i + 2]);
  }
  ++counters_.shares_queued;
  // Until the localizer has a map, a share's ECDSA runs as it completes, at most
  // kMaxSignatureVerificationsPerPeriod a period (before the first scan no period runs: every
  // queued share), instead of in the period that fuses it, which also builds the first map. Its
  // verdict is used at the period boundary as every other share's, so only where the work falls
  // changes, not the outcome.
  const bool before_first_scan = ego_frames_ == 0;
  const bool no_map = share_filter_ != nullptr && share_filter_->awaiting_first_map();
  if ((before_first_scan || (no_map && checked_on_arrival_ < kMaxSignatureVerificationsPerPeriod)) &&
      verifier_.check_signature(q.job)) {
    ++checked_on_arrival_;
    ++counters_.signature_verifications;
    ++counters_.signatures_checked_on_arrival;
  }
  return kind(CloudKind::kMapQueued);
}

DecodedCloud InputDecoder::decode_completed() {
  DecodedCloud out;
  const auto kind = [&out](CloudKind k) {
    out.kind = k;
    return out;
  };
  if (!completed_pending_) return kind(CloudKind::kNone);
  completed_pending_ = false;
  const protocol::ReassembledCloud& cloud = reassembler_.completed();
  const protocol::CloudFrameInfo& info = cloud.info;
  Mat4d pose;
  const std::uint32_t n = cloud.point_count;
  if (!pose_to_matrix(info.pose, pose) || n > points_.size() || cloud.xyz.size() < 3u * n) {
    ++counters_.clouds_rejected;
    return kind(CloudKind::kRejected);
  }
  const double t = localizer_time_s(static_cast<std::int64_t>(info.timestamp_ns), epoch_ns_);

  if (info.type == protocol::CloudMessageType::kMapShare) return queue_share(cloud, pose, t);
  if (info.type != protocol::CloudMessageType::kEgoScan || info.sender_id != kEgoSenderId) {
    ++counters_.clouds_rejected;
    return kind(CloudKind::kRejected);
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    points_[i] = Vec3f(cloud.xyz[3u * i], cloud.xyz[3u * i + 1], cloud.xyz[3u * i + 2]);
  }
  const std::span<const Vec3f> points(points_.data(), n);
  begin_verification_period();  // an ego scan (used or refused) is the period boundary
  // Plausible time: near the local clock and newer than the last accepted scan. A refused scan is
  // counted and leaves no trace, so it cannot freeze the scans after it.
  const std::int64_t stamp = static_cast<std::int64_t>(info.timestamp_ns & 0x7FFFFFFFFFFFFFFFull);
  if (info.timestamp_ns > 0x7FFFFFFFFFFFFFFFull || stamp > completed_local_time_ns_ + kEgoScanMaxClockSkewNs ||
      stamp < completed_local_time_ns_ - kEgoScanMaxClockSkewNs ||
      (have_ego_time_ && info.timestamp_ns <= last_ego_stamp_ns_)) {
    ++counters_.ego_time_rejected;
    out.frame_index = ego_frames_++;
    return kind(CloudKind::kEgoRejected);
  }
  have_ego_time_ = true;
  last_ego_stamp_ns_ = info.timestamp_ns;
  EgoScanInput& in = out.ego;
  in.t = t;
  in.points = points;
  if (cloud.time_offset_ticks.size() == n) {
    for (std::uint32_t i = 0; i < n; ++i) point_times_[i] = static_cast<float>(cloud.time_offset_ticks[i] * protocol::kPointTimeTick);
    in.point_times = std::span<const float>(point_times_.data(), n);
  }
  in.body_T_lidar = pose;
  out.gnss_used = gnss_since_last_scan_;
  gnss_since_last_scan_ = false;
  out.frame_index = ego_frames_++;
  ++counters_.ego_scans;
  return kind(CloudKind::kEgoScan);
}

DecodedCloud InputDecoder::next_verified_share() { return next_verified_share(nullptr); }

DecodedCloud InputDecoder::next_verified_share(const MapShareWanted* wanted) {
  DecodedCloud out;
  std::size_t at = 0;
  for (std::size_t k = 0; k < kShareVerifyQueueCapacity; ++k) {  // skips shares refused for their time
    if (!schedule_.release(at)) return out;
    QueuedShare& q = queue_[at];
    if (!q.judged) {  // completed after this period's boundary was opened: judged by that boundary
      q.judged = true;
      q.judge_time_ns = period_time_ns_;
    }
    const bool timely = verifier_.check_time(q.job, q.judge_time_ns).verdict == trust::ShareVerdict::kAccepted;
    const trust::TrustList& list = verifier_.trust_list();
    // Unknown signer: complete() refuses it.
    const trust::TrustedSigner* signer = q.job.signer_index < list.count ? &list.signers[q.job.signer_index] : nullptr;
    bool verify = timely && (wanted == nullptr || signer == nullptr || wanted->wants(signer->sender_id, q.t));
    std::uint64_t* refused = timely ? &counters_.shares_paced : &counters_.shares_untrusted;
    // An infrastructure cloud off its unit's surveyed background would be refused by map fusion
    // anyway: refused here, it does not take one of the period's signature checks (the scoring,
    // ~0.8 M, is a fifteenth of one; map fusion scores a cloud that passes again).
    if (verify && wanted != nullptr && signer != nullptr && signer->role == trust::SignerRole::kInfrastructure &&
        !wanted->fits_background(signer->sender_id, q.world_T_sensor,
                                 std::span<const Vec3f>(queue_points_[at].data(), q.point_count))) {
      verify = false;
      refused = &counters_.shares_off_background;
    }
    if (verify) break;
    ++*refused;
    schedule_.refund();  // no ECDSA was spent on it
    if (k + 1 == kShareVerifyQueueCapacity) return out;
  }
  const QueuedShare& q = queue_[at];
  if (!q.job.signature_checked) ++counters_.signature_verifications;
  // Charged to the period budget even when it ran before the first scan: which shares completed
  // before it depends on which socket was read first, the budget must not.
  trust_work_ += kShareVerifyInstructions;
  const trust::ShareVerifyResult verdict = verifier_.complete(q.job);
  if (verdict.verdict != trust::ShareVerdict::kAccepted) {
    ++counters_.shares_untrusted;
    out.kind = CloudKind::kRejected;
    return out;
  }
  MapCloudInput& in = out.map;
  in.source_id = verdict.signer->sender_id;
  in.is_agent = verdict.signer->role == trust::SignerRole::kAgent;
  in.t = q.t;
  in.world_T_sensor = q.world_T_sensor;
  in.points = std::span<const Vec3f>(queue_points_[at].data(), q.point_count);
  ++counters_.map_clouds;
  out.kind = CloudKind::kMapCloud;
  return out;
}

}  // namespace v2xloc::firmware
