#include "firmware/wire/pose_frames.hpp"

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::firmware {

protocol::PoseFlags pose_flags(const LocalizerFrameOutput& out, bool gnss_used) {
  protocol::PoseFlags f;
  f.pose_valid = out.localized;
  // A period without LiDAR points is the filter's prediction: never a registration, always dead reckoning.
  f.registration_valid = out.registration_fused && !out.no_scan_data;
  f.gnss_used = gnss_used;
  f.degraded = (out.mode != LocalizationMode::kUninitialized && !out.localized) ||
               (out.no_scan_data && out.filter_initialized);
  return f;
}

PoseFrames PoseFrameEncoder::encode(const LocalizerFrameOutput& out, std::uint32_t frame_index, bool gnss_used) {
  const protocol::PoseFlags flags = pose_flags(out, gnss_used);
  const Mat4d& T = out.fused_pose.matrix();
  protocol::PackStats stats;

  protocol::PosePosition position;
  position.x_m = T(0, 3);
  position.y_m = T(1, 3);
  position.flags = flags;
  position.counter = counter_;

  protocol::PoseAttitude attitude;
  attitude.z_m = T(2, 3);
  attitude.yaw_rad = det::atan2(T(1, 0), T(0, 0));  // ENU yaw of the body x axis (det: same bits on every ISA)
  attitude.frame_counter = static_cast<std::uint16_t>(frame_index & 0xFFFFu);
  attitude.flags = flags;
  attitude.counter = counter_;

  protocol::PoseSigma sigma;
  sigma.sigma_x_m = out.sigma_x;
  sigma.sigma_y_m = out.sigma_y;
  sigma.sigma_z_m = out.sigma_z;
  sigma.sigma_yaw_rad = out.sigma_yaw;
  sigma.counter = counter_;

  PoseFrames frames{protocol::pack(position, &stats), protocol::pack(attitude, &stats), protocol::pack(sigma, &stats)};
  saturated_ += stats.saturated;
  counter_ = static_cast<std::uint8_t>((counter_ + 1) % protocol::kCounterModulo);
  return frames;
}

protocol::LocalizerState localizer_state(const LocalizerFrameOutput* latest) {
  if (latest == nullptr) return protocol::LocalizerState::kInit;
  switch (latest->mode) {
    case LocalizationMode::kUninitialized: return protocol::LocalizerState::kWaitingForGnss;
    case LocalizationMode::kGlobalSearch: return protocol::LocalizerState::kLocalizing;
    case LocalizationMode::kTracking:
      return latest->localized ? protocol::LocalizerState::kLocalized : protocol::LocalizerState::kDegraded;
  }
  return protocol::LocalizerState::kFault;
}

}  // namespace v2xloc::firmware
