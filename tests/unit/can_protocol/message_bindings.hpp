// Binds each DBC message to the codec's physical struct by signal name, so tests can drive any
// message generically: physical values in by name -> pack; unpack -> physical values by name.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "firmware/protocol/can_messages.hpp"

namespace v2xloc::test {

using Values = std::map<std::string, double>;

struct MessageBinding {
  std::uint32_t id;
  std::function<hal::CanFrame(const Values&, protocol::PackStats*)> pack;
  std::function<protocol::DecodeStatus(const hal::CanFrame&, Values&)> unpack;
};

namespace detail {
inline double get(const Values& v, const char* name) {
  const auto it = v.find(name);
  return it == v.end() ? 0.0 : it->second;
}
template <class T>
T as(const Values& v, const char* name) {
  return static_cast<T>(get(v, name));
}
inline void set_flags(protocol::PoseFlags& f, const Values& v) {
  f.pose_valid = get(v, "PoseValid") != 0.0;
  f.registration_valid = get(v, "RegistrationValid") != 0.0;
  f.gnss_used = get(v, "GnssUsed") != 0.0;
  f.degraded = get(v, "Degraded") != 0.0;
}
inline void get_flags(const protocol::PoseFlags& f, Values& v) {
  v["PoseValid"] = f.pose_valid;
  v["RegistrationValid"] = f.registration_valid;
  v["GnssUsed"] = f.gnss_used;
  v["Degraded"] = f.degraded;
}
}  // namespace detail

inline std::vector<MessageBinding> message_bindings() {
  using namespace protocol;
  using detail::as;
  using detail::get;
  std::vector<MessageBinding> b;
  b.push_back({kVehicleMotionId,
               [](const Values& v, PackStats* s) {
                 VehicleMotion m;
                 m.wheel_speed_mps = get(v, "WheelSpeed");
                 m.yaw_rate_rps = get(v, "YawRate");
                 m.speed_valid = get(v, "SpeedValid") != 0.0;
                 m.yaw_rate_valid = get(v, "YawRateValid") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 VehicleMotion m;
                 const auto st = unpack(f, m);
                 v = {{"WheelSpeed", m.wheel_speed_mps}, {"YawRate", m.yaw_rate_rps}, {"SpeedValid", m.speed_valid},
                      {"YawRateValid", m.yaw_rate_valid}, {"Counter", m.counter}};
                 return st;
               }});
  // Multiplexed: PositionMux picks the signal the frame carries (Latitude m0, Longitude m1).
  b.push_back({kGnssPositionId,
               [](const Values& v, PackStats* s) {
                 GnssPosition m;
                 const bool lon = get(v, "PositionMux") != 0.0;
                 m.half = lon ? GnssPositionHalf::kLongitude : GnssPositionHalf::kLatitude;
                 m.deg = get(v, lon ? "Longitude" : "Latitude");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GnssPosition m;
                 const auto st = unpack(f, m);
                 const bool lon = m.half == GnssPositionHalf::kLongitude;
                 v = {{"PositionMux", lon ? 1.0 : 0.0}, {lon ? "Longitude" : "Latitude", m.deg}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kGnssStatusId,
               [](const Values& v, PackStats* s) {
                 GnssStatus m;
                 m.alt_m = get(v, "Altitude");
                 m.h_acc_m = get(v, "HorizontalAccuracy");
                 m.v_acc_m = get(v, "VerticalAccuracy");
                 m.num_sats = as<std::uint8_t>(v, "NumSatellites");
                 m.fix_type = static_cast<GnssFixType>(as<std::uint8_t>(v, "FixType"));
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GnssStatus m;
                 const auto st = unpack(f, m);
                 v = {{"Altitude", m.alt_m}, {"HorizontalAccuracy", m.h_acc_m}, {"VerticalAccuracy", m.v_acc_m},
                      {"NumSatellites", m.num_sats}, {"FixType", static_cast<double>(m.fix_type)}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kGnssTimeId,
               [](const Values& v, PackStats* s) {
                 GnssTime m;
                 m.time_of_week_s = get(v, "TimeOfWeek");
                 m.week = as<std::uint16_t>(v, "Week");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GnssTime m;
                 const auto st = unpack(f, m);
                 v = {{"TimeOfWeek", m.time_of_week_s}, {"Week", m.week}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kGnssDopId,
               [](const Values& v, PackStats* s) {
                 GnssDop m;
                 m.hdop = get(v, "Hdop");
                 m.pdop = get(v, "Pdop");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GnssDop m;
                 const auto st = unpack(f, m);
                 v = {{"Hdop", m.hdop}, {"Pdop", m.pdop}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kGnssVelocityId,
               [](const Values& v, PackStats* s) {
                 GnssVelocity m;
                 m.vel_east_mps = get(v, "VelEast");
                 m.vel_north_mps = get(v, "VelNorth");
                 m.vel_up_mps = get(v, "VelUp");
                 m.speed_acc_mps = get(v, "SpeedAccuracy");
                 m.valid = get(v, "VelocityValid") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GnssVelocity m;
                 const auto st = unpack(f, m);
                 v = {{"VelEast", m.vel_east_mps}, {"VelNorth", m.vel_north_mps}, {"VelUp", m.vel_up_mps},
                      {"SpeedAccuracy", m.speed_acc_mps}, {"VelocityValid", m.valid ? 1.0 : 0.0}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kPosePositionId,
               [](const Values& v, PackStats* s) {
                 PosePosition m;
                 m.x_m = get(v, "PoseX");
                 m.y_m = get(v, "PoseY");
                 detail::set_flags(m.flags, v);
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 PosePosition m;
                 const auto st = unpack(f, m);
                 v = {{"PoseX", m.x_m}, {"PoseY", m.y_m}, {"Counter", m.counter}};
                 detail::get_flags(m.flags, v);
                 return st;
               }});
  b.push_back({kPoseAttitudeId,
               [](const Values& v, PackStats* s) {
                 PoseAttitude m;
                 m.z_m = get(v, "PoseZ");
                 m.yaw_rad = get(v, "PoseYaw");
                 m.frame_counter = as<std::uint16_t>(v, "FrameCounter");
                 detail::set_flags(m.flags, v);
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 PoseAttitude m;
                 const auto st = unpack(f, m);
                 v = {{"PoseZ", m.z_m}, {"PoseYaw", m.yaw_rad}, {"FrameCounter", m.frame_counter}, {"Counter", m.counter}};
                 detail::get_flags(m.flags, v);
                 return st;
               }});
  b.push_back({kPoseSigmaId,
               [](const Values& v, PackStats* s) {
                 PoseSigma m;
                 m.sigma_x_m = get(v, "SigmaX");
                 m.sigma_y_m = get(v, "SigmaY");
                 m.sigma_z_m = get(v, "SigmaZ");
                 m.sigma_yaw_rad = get(v, "SigmaYaw");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 PoseSigma m;
                 const auto st = unpack(f, m);
                 v = {{"SigmaX", m.sigma_x_m}, {"SigmaY", m.sigma_y_m}, {"SigmaZ", m.sigma_z_m},
                      {"SigmaYaw", m.sigma_yaw_rad}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kRegistrationPositionId,
               [](const Values& v, PackStats* s) {
                 RegistrationPosition m;
                 m.x_m = get(v, "RegX");
                 m.y_m = get(v, "RegY");
                 m.attempted = get(v, "RegAttempted") != 0.0;
                 m.ok = get(v, "RegOk") != 0.0;
                 m.clamped = get(v, "RegClamped") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 RegistrationPosition m;
                 const auto st = unpack(f, m);
                 v = {{"RegX", m.x_m}, {"RegY", m.y_m}, {"RegAttempted", m.attempted}, {"RegOk", m.ok},
                      {"RegClamped", m.clamped}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kRegistrationQualityId,
               [](const Values& v, PackStats* s) {
                 RegistrationQuality m;
                 m.z_m = get(v, "RegZ");
                 m.fitness = get(v, "RegFitness");
                 m.inlier_rmse_m = get(v, "RegRmse");
                 m.frame_counter = as<std::uint16_t>(v, "FrameCounter");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 RegistrationQuality m;
                 const auto st = unpack(f, m);
                 v = {{"RegZ", m.z_m}, {"RegFitness", m.fitness}, {"RegRmse", m.inlier_rmse_m},
                      {"FrameCounter", m.frame_counter}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kGateDecisionId,
               [](const Values& v, PackStats* s) {
                 GateDecision m;
                 m.decided_frame = as<std::uint16_t>(v, "DecidedFrame");
                 m.frame_counter = as<std::uint16_t>(v, "FrameCounter");
                 m.decided = get(v, "GateDecided") != 0.0;
                 m.valid = get(v, "GateValid") != 0.0;
                 m.mode = static_cast<LocalizerModeCode>(as<std::uint8_t>(v, "Mode"));
                 m.filter_initialized = get(v, "FilterInitialized") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 GateDecision m;
                 const auto st = unpack(f, m);
                 v = {{"DecidedFrame", m.decided_frame}, {"FrameCounter", m.frame_counter}, {"GateDecided", m.decided},
                      {"GateValid", m.valid}, {"Mode", static_cast<double>(m.mode)},
                      {"FilterInitialized", m.filter_initialized}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kOdometryPositionId,
               [](const Values& v, PackStats* s) {
                 OdometryPosition m;
                 m.x_m = get(v, "OdomX");
                 m.y_m = get(v, "OdomY");
                 m.odometry_ok = get(v, "OdometryOk") != 0.0;
                 m.clamped = get(v, "OdomClamped") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 OdometryPosition m;
                 const auto st = unpack(f, m);
                 v = {{"OdomX", m.x_m}, {"OdomY", m.y_m}, {"OdometryOk", m.odometry_ok}, {"OdomClamped", m.clamped},
                      {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kOdometryAttitudeId,
               [](const Values& v, PackStats* s) {
                 OdometryAttitude m;
                 m.z_m = get(v, "OdomZ");
                 m.yaw_rad = get(v, "OdomYaw");
                 m.frame_counter = as<std::uint16_t>(v, "FrameCounter");
                 m.odometry_ok = get(v, "OdometryOk") != 0.0;
                 m.clamped = get(v, "OdomClamped") != 0.0;
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 OdometryAttitude m;
                 const auto st = unpack(f, m);
                 v = {{"OdomZ", m.z_m}, {"OdomYaw", m.yaw_rad}, {"FrameCounter", m.frame_counter},
                      {"OdometryOk", m.odometry_ok}, {"OdomClamped", m.clamped}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kHeartbeatId,
               [](const Values& v, PackStats* s) {
                 Heartbeat m;
                 m.state = static_cast<LocalizerState>(as<std::uint8_t>(v, "State"));
                 m.error_flags = as<std::uint8_t>(v, "ErrorFlags");
                 m.uptime_s = get(v, "Uptime");
                 m.can_rx_errors = as<std::uint8_t>(v, "CanRxErrors");
                 m.udp_dropped = as<std::uint8_t>(v, "UdpDropped");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 Heartbeat m;
                 const auto st = unpack(f, m);
                 v = {{"State", static_cast<double>(m.state)}, {"ErrorFlags", m.error_flags}, {"Uptime", m.uptime_s},
                      {"CanRxErrors", m.can_rx_errors}, {"UdpDropped", m.udp_dropped}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kTrustRejectionsId,
               [](const Values& v, PackStats* s) {
                 TrustRejections m;
                 m.unknown_signer = as<std::uint8_t>(v, "UnknownSigner");
                 m.bad_signature = as<std::uint8_t>(v, "BadSignature");
                 m.too_old = as<std::uint8_t>(v, "TooOld");
                 m.future = as<std::uint8_t>(v, "Future");
                 m.replay = as<std::uint8_t>(v, "Replay");
                 m.queue_overflow = as<std::uint8_t>(v, "QueueOverflow");
                 m.pose_mismatch = as<std::uint8_t>(v, "PoseMismatch");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 TrustRejections m;
                 const auto st = unpack(f, m);
                 v = {{"UnknownSigner", m.unknown_signer}, {"BadSignature", m.bad_signature}, {"TooOld", m.too_old},
                      {"Future", m.future}, {"Replay", m.replay}, {"QueueOverflow", m.queue_overflow},
                      {"PoseMismatch", m.pose_mismatch}, {"Counter", m.counter}};
                 return st;
               }});
  b.push_back({kInputGuardsId,
               [](const Values& v, PackStats* s) {
                 InputGuards m;
                 m.can_crc_rejected = as<std::uint16_t>(v, "CanCrcRejected");
                 m.can_counter_rejected = as<std::uint16_t>(v, "CanCounterRejected");
                 m.ego_time_rejected = as<std::uint16_t>(v, "EgoTimeRejected");
                 m.missing_signature = as<std::uint16_t>(v, "MissingSignature");
                 m.background_mismatch = as<std::uint8_t>(v, "BackgroundMismatch");
                 m.counter = as<std::uint8_t>(v, "Counter");
                 return pack(m, s);
               },
               [](const CanFrame& f, Values& v) {
                 InputGuards m;
                 const auto st = unpack(f, m);
                 v = {{"CanCrcRejected", m.can_crc_rejected}, {"CanCounterRejected", m.can_counter_rejected},
                      {"EgoTimeRejected", m.ego_time_rejected}, {"MissingSignature", m.missing_signature},
                      {"BackgroundMismatch", m.background_mismatch}, {"Counter", m.counter}};
                 return st;
               }});
  return b;
}

}  // namespace v2xloc::test
