#include "firmware/wire/period_driver.hpp"

#include <limits>

#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware {

std::uint64_t imu_digest_step(std::uint64_t h, const ImuInput& s) {
  Fnv1a64 f{h};
  f.bytes(&s.t, sizeof s.t);
  f.bytes(s.gyro, sizeof s.gyro);
  f.bytes(s.accel, sizeof s.accel);
  const unsigned char saturated = s.saturated ? 1 : 0;
  f.bytes(&saturated, 1);
  return f.h;
}

PeriodDriver::PeriodDriver(InputDecoder& decoder, LocalizerPort& localizer) : decoder_(decoder), localizer_(localizer) {
  decoder_.set_share_filter(&localizer_);
}

DecodedCan PeriodDriver::on_can(const hal::CanFrame& frame, std::int64_t time_ns) {
  const DecodedCan decoded = decoder_.decode_can(frame, time_ns);
  timer_.on_input(localizer_time_s(time_ns, decoder_.epoch_ns()));
  if (time_ns > input_time_ns_) input_time_ns_ = time_ns;
  PendingInput input;
  if (decoded.kind == CanInputKind::kVehicle) {
    input.kind = PendingInput::Kind::kVehicle;
    input.vehicle = decoded.vehicle;
    hold(input);
  }
  if (decoded.kind == CanInputKind::kGnssFix) {
    input.kind = PendingInput::Kind::kGnss;
    input.gnss = decoded.gnss;
    hold(input);
  }
  return decoded;
}

// A LiDAR that stops sending leaves the period open: past the capacity the held inputs go early.
void PeriodDriver::hold(const PendingInput& input) {
  if (pending_.full()) {
    counters_.inputs_released_early += pending_.size();
    release_inputs();
  }
  pending_.push(input);
}

DecodedCloud PeriodDriver::take_completed(std::int64_t local_time_ns) { return decoder_.decode_completed(local_time_ns); }

DecodedCloud PeriodDriver::take_completed() { return decoder_.decode_completed(); }

void PeriodDriver::count_insert(const MapInsertResult& result, bool is_agent) {
  ++counters_.map_handed;
  switch (result.status) {
    case MapInsertStatus::kInserted:
    case MapInsertStatus::kReplaced: ++counters_.map_fused; break;
    case MapInsertStatus::kRejectedInconsistent:
      ++counters_.map_inconsistent;
      if (!is_agent) ++counters_.map_infra_inconsistent;
      break;
    case MapInsertStatus::kHeldBack: ++counters_.map_held_back; break;
    case MapInsertStatus::kBackgroundMismatch: ++counters_.map_background_mismatch; break;
    case MapInsertStatus::kNoSourceSlot: ++counters_.map_no_slot; break;
    case MapInsertStatus::kStale: ++counters_.map_stale; break;
    case MapInsertStatus::kPaced: ++counters_.map_paced; break;
    case MapInsertStatus::kInvalidInput: break;
  }
}

// The queued IMU samples older than t, oldest first (the decoder keeps them in strictly
// increasing time).
void PeriodDriver::release_imu_before(double t) {
  ImuInput sample;
  while (decoder_.imu().peek() != nullptr && decoder_.imu().peek()->t < t && decoder_.imu().take(sample)) {
    ++counters_.imu_handed;
    counters_.imu_digest = imu_digest_step(counters_.imu_digest, sample);
    localizer_.on_imu(sample);
  }
}

// The held CAN inputs in arrival order, each after the IMU samples older than it, then every
// remaining sample received up to now.
void PeriodDriver::release_inputs() { release_inputs_until(std::numeric_limits<double>::infinity()); }

// The same for a period ending at t: the held inputs stamped up to t (in arrival order, up to the
// first later one) and the samples before t; the rest wait for the next period.
void PeriodDriver::release_inputs_until(double t) {
  for (; !pending_.empty() && pending_.front().t() <= t; pending_.pop()) {
    const PendingInput& input = pending_.front();
    release_imu_before(input.t());
    if (input.kind == PendingInput::Kind::kVehicle) {
      localizer_.on_vehicle(input.vehicle);
    } else {
      localizer_.on_gnss(input.gnss);
      gnss_released_ = true;
    }
  }
  release_imu_before(t);
}

// The period's share budget: the schedule's cap or the localizer's (one while tracking). Shares
// refused before their signature check do not use it (ShareVerificationQueue::next_verified_share).
void PeriodDriver::release_shares() {
  const std::size_t shares = shares_this_period(localizer_.map_clouds_per_period());
  for (std::size_t k = 0; k < shares; ++k) {
    const DecodedCloud share = decoder_.next_verified_share(&localizer_);
    if (share.kind == CloudKind::kNone) break;
    if (share.kind == CloudKind::kMapCloud) count_insert(localizer_.on_map_cloud(share.map), share.map.is_agent);
  }
}

const PeriodOutput& PeriodDriver::close_with_scan(const DecodedCloud& scan) {
  ++counters_.periods;
  release_inputs();
  release_shares();
  // Trust work (hashing, ECDSA) counts against this period's budget; a refused scan ends the
  // period without a localizer frame, so its work is dropped with it.
  const double trust_work = decoder_.take_trust_work();
  published_.held = scan.kind != CloudKind::kEgoScan;
  bool gnss_used = false;
  if (published_.held) {
    ++counters_.ego_frames_held;  // a pose every frame: the last one again, or "no pose" before any
    timer_.closed_by_refused_scan();  // its stamp is not trusted
  } else {
    localizer_.add_period_work(trust_work);
    latest_ = localizer_.on_ego_scan(scan.ego);
    gnss_used = scan.gnss_used;
    body_T_lidar_ = scan.ego.body_T_lidar;
    timer_.closed_by_scan(scan.ego.t);
  }
  published_.without_scan = false;
  return publish_latest(gnss_used);
}

// The period the timer names, closed at its expected stamp t with a scan without points; the
// waiting shares too when a CAN input closed it (the period boundary is that input's time).
const PeriodOutput& PeriodDriver::close_without_scan(double t, bool release_shares_now) {
  ++counters_.periods;
  ++counters_.periods_without_scan;
  gnss_released_ = false;
  release_inputs_until(t);
  if (release_shares_now) {
    decoder_.shares().begin_period(input_time_ns_);
    release_shares();
    localizer_.add_period_work(decoder_.take_trust_work());
  }
  EgoScanInput empty;
  empty.t = t;
  empty.body_T_lidar = body_T_lidar_;
  latest_ = localizer_.on_ego_scan(empty);
  published_.held = false;
  published_.without_scan = true;
  return publish_latest(gnss_released_);
}

const PeriodOutput& PeriodDriver::publish_latest(bool gnss_used) {
  const auto frame_index = static_cast<std::uint32_t>(counters_.periods - 1);
  has_output_ = true;
  published_.frame_index = frame_index;
  published_.gnss_used = gnss_used;
  published_.output = &latest_;
  published_.pose = pose_encoder_.encode(latest_, frame_index, gnss_used);
  published_.diagnostics = diagnostic_encoder_.encode(latest_, frame_index);
  return published_;
}

}  // namespace v2xloc::firmware
