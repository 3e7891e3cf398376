#include "firmware/wire/diagnostic_frames.hpp"

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::firmware {
namespace {

protocol::LocalizerModeCode mode_code(LocalizationMode mode) {
  switch (mode) {
    case LocalizationMode::kUninitialized: return protocol::LocalizerModeCode::kUninitialized;
    case LocalizationMode::kGlobalSearch: return protocol::LocalizerModeCode::kGlobalSearch;
    case LocalizationMode::kTracking: return protocol::LocalizerModeCode::kTracking;
  }
  return protocol::LocalizerModeCode::kUninitialized;
}

}  // namespace

DiagnosticFrames DiagnosticFrameEncoder::encode(const LocalizerFrameOutput& out, std::uint32_t frame_index) {
  const auto frame_counter = static_cast<std::uint16_t>(frame_index & 0xFFFFu);
  DiagnosticFrames frames;

  // Registration: 0x211 first, so a clamped z / RMSE raises the flag carried by 0x210.
  const Mat4d& R = out.registration_pose.matrix();
  protocol::RegistrationQuality quality;
  quality.z_m = R(2, 3);
  quality.fitness = out.fitness;
  quality.inlier_rmse_m = out.inlier_rmse;
  quality.frame_counter = frame_counter;
  quality.counter = counter_;
  protocol::PackStats registration_stats;
  frames.registration_quality = protocol::pack(quality, &registration_stats);
  protocol::RegistrationPosition position;
  position.x_m = R(0, 3);
  position.y_m = R(1, 3);
  position.attempted = out.registration_attempted;
  position.ok = out.registration_attempted && out.registration_status == RegistrationStatus::kOk;
  position.clamped = registration_stats.saturated != 0u;
  position.counter = counter_;
  frames.registration_position = protocol::pack(position, &registration_stats);

  protocol::GateDecision gate;
  gate.decided = out.gate_decided;
  gate.decided_frame = static_cast<std::uint16_t>(out.gate_decided ? out.gate_decided_frame & 0xFFFFu : 0u);
  gate.valid = out.gate_decided && out.gate_decided_valid;
  gate.frame_counter = frame_counter;
  gate.mode = mode_code(out.mode);
  gate.filter_initialized = out.filter_initialized;
  gate.counter = counter_;
  protocol::PackStats gate_stats;
  frames.gate = protocol::pack(gate, &gate_stats);

  // Odometry: the clamped flag covers both frames, so 0x214 is packed first, then 0x213, and
  // 0x214 again with the flag when only 0x213 saturated.
  const Mat4d& O = out.odometry_pose.matrix();
  protocol::OdometryAttitude attitude;
  attitude.z_m = O(2, 3);
  attitude.yaw_rad = det::atan2(O(1, 0), O(0, 0));
  attitude.frame_counter = frame_counter;
  attitude.odometry_ok = out.odometry_ok;
  attitude.counter = counter_;
  protocol::PackStats attitude_stats;
  frames.odometry_attitude = protocol::pack(attitude, &attitude_stats);
  protocol::OdometryPosition odom_position;
  odom_position.x_m = O(0, 3);
  odom_position.y_m = O(1, 3);
  odom_position.odometry_ok = out.odometry_ok;
  odom_position.clamped = attitude_stats.saturated != 0u;
  odom_position.counter = counter_;
  protocol::PackStats odom_position_stats;
  frames.odometry_position = protocol::pack(odom_position, &odom_position_stats);
  if (odom_position_stats.saturated != 0u && attitude_stats.saturated == 0u) {
    attitude.clamped = true;
    frames.odometry_attitude = protocol::pack(attitude);
  }

  saturated_ += registration_stats.saturated + gate_stats.saturated + attitude_stats.saturated +
                odom_position_stats.saturated;
  counter_ = static_cast<std::uint8_t>((counter_ + 1) % protocol::kCounterModulo);
  return frames;
}

}  // namespace v2xloc::firmware
