#include "firmware/wire/can_input_decoder.hpp"

#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware {

DecodedCan CanInputDecoder::decode(const hal::CanFrame& frame, std::int64_t time_ns) {
  ++counters_.can_frames;
  const double t = localizer_time_s(time_ns, epoch_ns_);
  switch (frame.id) {
    case protocol::kVehicleMotionId: return decode_vehicle(frame, t);
    case protocol::kGnssPositionId: return decode_position(frame);
    case protocol::kGnssStatusId: return decode_gnss_part(frame, gnss_status_counter_, &GnssFixAssembler::set_status);
    case protocol::kGnssVelocityId:
      return decode_gnss_part(frame, gnss_velocity_counter_, &GnssFixAssembler::set_velocity);
    case protocol::kGnssDopId: return decode_gnss_part(frame, gnss_dop_counter_, &GnssFixAssembler::set_dop);
    case protocol::kGnssTimeId: return decode_time(frame, t);
    default:
      ++counters_.can_unknown_id;
      return with_kind(CanInputKind::kUnknownId);
  }
}

DecodedCan CanInputDecoder::with_kind(CanInputKind kind) {
  DecodedCan out;
  out.kind = kind;
  return out;
}

bool CanInputDecoder::counter_ok(protocol::RollingCounterMonitor& monitor, std::uint8_t counter) {
  const std::uint32_t repeated = monitor.repeated(), lost = monitor.lost();
  monitor.update(counter);
  counters_.can_counter_gaps += monitor.lost() - lost;
  if (monitor.repeated() != repeated) {
    ++counters_.can_repeated;
    return false;
  }
  return true;
}

// Unpacks into a scratch copy, so a frame refused for its range or counter leaves `out` as it was.
template <typename M>
bool CanInputDecoder::accept(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& out) {
  M m;
  if (protocol::unpack(frame, m) != protocol::DecodeStatus::kOk) {
    ++counters_.can_rejected;
    return false;
  }
  if (!counter_ok(monitor, m.counter)) return false;
  out = m;
  return true;
}

DecodedCan CanInputDecoder::decode_vehicle(const hal::CanFrame& frame, double t) {
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
DecodedCan CanInputDecoder::decode_gnss_part(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor,
                                             void (GnssFixAssembler::*store)(const M&)) {
  M part;
  if (!accept(frame, monitor, part)) return with_kind(CanInputKind::kRejected);
  (fix_.*store)(part);
  return with_kind(CanInputKind::kGnssPart);
}

void CanInputDecoder::count_positions_dropped(std::uint32_t before) {
  counters_.gnss_position_dropped += fix_.positions_dropped() - before;
}

DecodedCan CanInputDecoder::decode_position(const hal::CanFrame& frame) {
  protocol::GnssPosition half;
  if (!accept(frame, gnss_position_counter_, half)) return with_kind(CanInputKind::kRejected);
  const std::uint32_t dropped = fix_.positions_dropped();
  const protocol::GnssPositionPairer::Result r = fix_.add_position(half);
  count_positions_dropped(dropped);
  if (r == protocol::GnssPositionPairer::Result::kDropped) return with_kind(CanInputKind::kInvalid);
  return with_kind(CanInputKind::kGnssPart);
}

// The time frame closes the fix (sent last); a fix without its status frame is counted incomplete.
DecodedCan CanInputDecoder::decode_time(const hal::CanFrame& frame, double t) {
  if (!accept(frame, gnss_time_counter_, gnss_time_)) return with_kind(CanInputKind::kRejected);
  const std::uint32_t dropped = fix_.positions_dropped();
  DecodedCan out = with_kind(CanInputKind::kGnssFix);
  const bool complete = fix_.close(t, out.gnss);
  count_positions_dropped(dropped);
  if (!complete) {
    ++counters_.gnss_incomplete;
    return with_kind(CanInputKind::kInvalid);
  }
  ++counters_.gnss_inputs;
  gnss_fix_seen_ = true;
  return out;
}

}  // namespace v2xloc::firmware
