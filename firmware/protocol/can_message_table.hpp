// Every CAN message of v2xloc, described once: its signals as in tools/dbc/v2xloc.dbc (one line a
// DBC `SG_`, the CRC in byte 7 aside), each bound to the member of the message struct it carries.
// The generic codec (can_messages.hpp) packs and reads frames from this table alone;
// tests/unit/can_protocol holds it to the DBC signal by signal and derives its test bindings from it.
#pragma once

#include <cstddef>
#include <tuple>
#include <type_traits>
#include <utility>

#include "firmware/protocol/can_message_types.hpp"
#include "firmware/protocol/can_signal.hpp"

namespace v2xloc::protocol::can_table {

constexpr Sign kSigned = Sign::kSigned;
constexpr Sign kUnsigned = Sign::kUnsigned;

inline constexpr std::tuple kMessages{
    message<VehicleMotion>(
        kVehicleMotionId, "VehicleMotion",
        field(&VehicleMotion::wheel_speed_mps, scaled("WheelSpeed", 0, 16, kSigned, 0.01, 0.0, -327.68, 327.67)),
        field(&VehicleMotion::yaw_rate_rps, scaled("YawRate", 16, 16, kSigned, 0.0001, 0.0, -3.2768, 3.2767)),
        field(&VehicleMotion::speed_valid, flag("SpeedValid", 32)),
        field(&VehicleMotion::yaw_rate_valid, flag("YawRateValid", 33)),
        field(&VehicleMotion::counter, rolling_counter(48))),
    // Latitude and longitude take the same bits; PositionMux says which one the frame carries.
    message<GnssPosition>(
        kGnssPositionId, "GnssPosition",
        field(&GnssPosition::half, multiplexer("PositionMux", 32)),
        field(&GnssPosition::deg, multiplexed(scaled("Latitude", 0, 32, kSigned, 1e-7, 0.0, -90.0, 90.0), 0)),
        field(&GnssPosition::deg, multiplexed(scaled("Longitude", 0, 32, kSigned, 1e-7, 0.0, -180.0, 180.0), 1)),
        field(&GnssPosition::counter, rolling_counter(52))),
    message<GnssStatus>(
        kGnssStatusId, "GnssStatus",
        field(&GnssStatus::alt_m, scaled("Altitude", 0, 20, kUnsigned, 0.01, -1000.0, -1000.0, 9485.75)),
        field(&GnssStatus::h_acc_m, scaled("HorizontalAccuracy", 20, 12, kUnsigned, 0.05, 0.0, 0.0, 204.75)),
        field(&GnssStatus::v_acc_m, scaled("VerticalAccuracy", 32, 12, kUnsigned, 0.05, 0.0, 0.0, 204.75)),
        field(&GnssStatus::num_sats, integer("NumSatellites", 44, 6, 63.0)),
        field(&GnssStatus::fix_type, integer("FixType", 50, 2, 3.0)),
        field(&GnssStatus::counter, rolling_counter(52))),
    message<GnssTime>(
        kGnssTimeId, "GnssTime",
        field(&GnssTime::time_of_week_s, scaled("TimeOfWeek", 0, 32, kUnsigned, 0.001, 0.0, 0.0, 604799.999)),
        field(&GnssTime::week, integer("Week", 32, 16, 65535.0)),
        field(&GnssTime::counter, rolling_counter(52))),
    message<GnssVelocity>(
        kGnssVelocityId, "GnssVelocity",
        field(&GnssVelocity::vel_east_mps, scaled("VelEast", 0, 16, kSigned, 0.01, 0.0, -327.68, 327.67)),
        field(&GnssVelocity::vel_north_mps, scaled("VelNorth", 16, 16, kSigned, 0.01, 0.0, -327.68, 327.67)),
        field(&GnssVelocity::vel_up_mps, scaled("VelUp", 32, 11, kSigned, 0.01, 0.0, -10.24, 10.23)),
        field(&GnssVelocity::speed_acc_mps, scaled("SpeedAccuracy", 43, 8, kUnsigned, 0.02, 0.0, 0.0, 5.1)),
        field(&GnssVelocity::valid, flag("VelocityValid", 51)),
        field(&GnssVelocity::counter, rolling_counter(52))),
    message<GnssDop>(
        kGnssDopId, "GnssDop",
        field(&GnssDop::hdop, scaled("Hdop", 0, 8, kUnsigned, 0.1, 0.0, 0.0, 25.5)),
        field(&GnssDop::pdop, scaled("Pdop", 8, 8, kUnsigned, 0.1, 0.0, 0.0, 25.5)),
        field(&GnssDop::counter, rolling_counter(52))),
    message<PosePosition>(
        kPosePositionId, "PosePosition",
        field(&PosePosition::x_m, scaled("PoseX", 0, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&PosePosition::y_m, scaled("PoseY", 24, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&PosePosition::flags, &PoseFlags::pose_valid, flag("PoseValid", 48)),
        field(&PosePosition::flags, &PoseFlags::registration_valid, flag("RegistrationValid", 49)),
        field(&PosePosition::flags, &PoseFlags::gnss_used, flag("GnssUsed", 50)),
        field(&PosePosition::flags, &PoseFlags::degraded, flag("Degraded", 51)),
        field(&PosePosition::counter, rolling_counter(52))),
    message<PoseAttitude>(
        kPoseAttitudeId, "PoseAttitude",
        field(&PoseAttitude::z_m, scaled("PoseZ", 0, 16, kSigned, 0.01, 0.0, -327.68, 327.67)),
        field(&PoseAttitude::yaw_rad, angle("PoseYaw", 16, 16, 0.0001, 3.1416)),
        field(&PoseAttitude::frame_counter, integer("FrameCounter", 32, 16, 65535.0)),
        field(&PoseAttitude::flags, &PoseFlags::pose_valid, flag("PoseValid", 48)),
        field(&PoseAttitude::flags, &PoseFlags::registration_valid, flag("RegistrationValid", 49)),
        field(&PoseAttitude::flags, &PoseFlags::gnss_used, flag("GnssUsed", 50)),
        field(&PoseAttitude::flags, &PoseFlags::degraded, flag("Degraded", 51)),
        field(&PoseAttitude::counter, rolling_counter(52))),
    message<PoseSigma>(
        kPoseSigmaId, "PoseSigma",
        field(&PoseSigma::sigma_x_m, scaled("SigmaX", 0, 12, kUnsigned, 0.005, 0.0, 0.0, 20.475)),
        field(&PoseSigma::sigma_y_m, scaled("SigmaY", 12, 12, kUnsigned, 0.005, 0.0, 0.0, 20.475)),
        field(&PoseSigma::sigma_z_m, scaled("SigmaZ", 24, 12, kUnsigned, 0.005, 0.0, 0.0, 20.475)),
        field(&PoseSigma::sigma_yaw_rad, scaled("SigmaYaw", 36, 12, kUnsigned, 0.0001, 0.0, 0.0, 0.4095)),
        field(&PoseSigma::counter, rolling_counter(48))),
    message<RegistrationPosition>(
        kRegistrationPositionId, "RegistrationPosition",
        field(&RegistrationPosition::x_m, scaled("RegX", 0, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&RegistrationPosition::y_m, scaled("RegY", 24, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&RegistrationPosition::attempted, flag("RegAttempted", 48)),
        field(&RegistrationPosition::ok, flag("RegOk", 49)),
        field(&RegistrationPosition::clamped, clamped_flag("RegClamped", 50)),
        field(&RegistrationPosition::counter, rolling_counter(52))),
    message<RegistrationQuality>(
        kRegistrationQualityId, "RegistrationQuality",
        field(&RegistrationQuality::z_m, scaled("RegZ", 0, 16, kSigned, 0.001, 0.0, -32.768, 32.767)),
        field(&RegistrationQuality::fitness, scaled("RegFitness", 16, 10, kUnsigned, 0.001, 0.0, 0.0, 1.023)),
        field(&RegistrationQuality::inlier_rmse_m, scaled("RegRmse", 26, 10, kUnsigned, 0.001, 0.0, 0.0, 1.023)),
        field(&RegistrationQuality::frame_counter, integer("FrameCounter", 36, 16, 65535.0)),
        field(&RegistrationQuality::counter, rolling_counter(52))),
    message<GateDecision>(
        kGateDecisionId, "GateDecision",
        field(&GateDecision::decided_frame, integer("DecidedFrame", 0, 16, 65535.0)),
        field(&GateDecision::frame_counter, integer("FrameCounter", 16, 16, 65535.0)),
        field(&GateDecision::decided, flag("GateDecided", 32)),
        field(&GateDecision::valid, flag("GateValid", 33)),
        field(&GateDecision::mode, integer("Mode", 34, 2, kLocalizerModeMax)),
        field(&GateDecision::filter_initialized, flag("FilterInitialized", 36)),
        field(&GateDecision::counter, rolling_counter(48))),
    message<OdometryPosition>(
        kOdometryPositionId, "OdometryPosition",
        field(&OdometryPosition::x_m, scaled("OdomX", 0, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&OdometryPosition::y_m, scaled("OdomY", 24, 24, kSigned, 0.001, 0.0, -8388.608, 8388.607)),
        field(&OdometryPosition::odometry_ok, flag("OdometryOk", 48)),
        field(&OdometryPosition::clamped, clamped_flag("OdomClamped", 49)),
        field(&OdometryPosition::counter, rolling_counter(52))),
    message<OdometryAttitude>(
        kOdometryAttitudeId, "OdometryAttitude",
        field(&OdometryAttitude::z_m, scaled("OdomZ", 0, 16, kSigned, 0.001, 0.0, -32.768, 32.767)),
        field(&OdometryAttitude::yaw_rad, angle("OdomYaw", 16, 16, 0.0001, 3.1416)),
        field(&OdometryAttitude::frame_counter, integer("FrameCounter", 32, 16, 65535.0)),
        field(&OdometryAttitude::odometry_ok, flag("OdometryOk", 48)),
        field(&OdometryAttitude::clamped, clamped_flag("OdomClamped", 49)),
        field(&OdometryAttitude::counter, rolling_counter(52))),
    message<Heartbeat>(
        kHeartbeatId, "Heartbeat",
        field(&Heartbeat::state, integer("State", 0, 4, kLocalizerStateMax)),
        field(&Heartbeat::error_flags, integer("ErrorFlags", 4, 4, 15.0)),
        field(&Heartbeat::uptime_s, scaled("Uptime", 8, 24, kUnsigned, 0.1, 0.0, 0.0, 1677721.5)),
        field(&Heartbeat::can_rx_errors, integer("CanRxErrors", 32, 8, 255.0)),
        field(&Heartbeat::udp_dropped, integer("UdpDropped", 40, 8, 255.0)),
        field(&Heartbeat::counter, rolling_counter(48)),
        field(&Heartbeat::lidar_timeout, flag("LidarTimeout", 52))),
    message<TrustRejections>(
        kTrustRejectionsId, "TrustRejections",
        field(&TrustRejections::unknown_signer, integer("UnknownSigner", 0, 8, 255.0)),
        field(&TrustRejections::bad_signature, integer("BadSignature", 8, 8, 255.0)),
        field(&TrustRejections::too_old, integer("TooOld", 16, 8, 255.0)),
        field(&TrustRejections::future, integer("Future", 24, 8, 255.0)),
        field(&TrustRejections::replay, integer("Replay", 32, 8, 255.0)),
        field(&TrustRejections::queue_overflow, integer("QueueOverflow", 40, 8, 255.0)),
        field(&TrustRejections::pose_mismatch, integer("PoseMismatch", 52, 4, 15.0)),
        field(&TrustRejections::counter, rolling_counter(48))),
    message<InputGuards>(
        kInputGuardsId, "InputGuards",
        field(&InputGuards::can_crc_rejected, integer("CanCrcRejected", 0, 12, kInputGuardsMax)),
        field(&InputGuards::can_counter_rejected, integer("CanCounterRejected", 12, 12, kInputGuardsMax)),
        field(&InputGuards::ego_time_rejected, integer("EgoTimeRejected", 24, 12, kInputGuardsMax)),
        field(&InputGuards::missing_signature, integer("MissingSignature", 36, 12, kInputGuardsMax)),
        field(&InputGuards::background_mismatch, integer("BackgroundMismatch", 52, 4, 15.0)),
        field(&InputGuards::counter, rolling_counter(48))),
};

}  // namespace v2xloc::protocol::can_table

namespace v2xloc::protocol {

inline constexpr std::size_t kCanMessageCount = std::tuple_size_v<decltype(can_table::kMessages)>;

// Calls visit(layout) for every message, in identifier order.
template <class Visit>
constexpr void for_each_can_message(Visit&& visit) {
  std::apply([&](const auto&... layout) { (visit(layout), ...); }, can_table::kMessages);
}

namespace detail {
// The position of M's layout in the table; kCanMessageCount when M is not a CAN message.
template <class M, std::size_t I = 0>
constexpr std::size_t layout_index() {
  if constexpr (I == kCanMessageCount) {
    return I;
  } else {
    using Layout = std::tuple_element_t<I, std::remove_const_t<decltype(can_table::kMessages)>>;
    if constexpr (std::is_same_v<typename Layout::Message, M>) return I;
    else return layout_index<M, I + 1>();
  }
}
}  // namespace detail

// The structs the table describes: what pack() and unpack() take.
template <class M>
concept CanMessage = detail::layout_index<M>() < kCanMessageCount;

template <CanMessage M>
constexpr const auto& can_layout() {
  return std::get<detail::layout_index<M>()>(can_table::kMessages);
}

static_assert(
    [] {
      bool ok = true;
      for_each_can_message([&](const auto& layout) { ok = ok && layout_is_consistent(layout); });
      return ok;
    }(),
    "a CAN message layout overlaps, leaves bytes 0..6, lacks its counter or has a member too narrow");

}  // namespace v2xloc::protocol
