#include "v2xloc/algo/localization/frame_output.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

void FrameOutput::fill(const OutputFrame& f, const PoseFilter& filter, LocalizerFrameOutput& out,
                       LocalizerCounters& counters) const {
  out.t = f.t;
  out.filter_initialized = filter.initialized();
  if (filter.initialized()) {
    fill_from_filter(filter, out);
  } else {
    fill_before_start(f, out, counters);
  }
}

void FrameOutput::fill_from_filter(const PoseFilter& filter, LocalizerFrameOutput& out) const {
  out.fused_pose = filter.pose();
  out.fused_pose_ungated = filter.has_shadow() ? filter.shadow_pose() : out.fused_pose;
  const EkfCovariance& P = filter.ekf().covariance();
  out.sigma_x = std::sqrt(P(ekf_index::kPosX, ekf_index::kPosX));
  out.sigma_y = std::sqrt(P(ekf_index::kPosY, ekf_index::kPosY));
  out.sigma_z = std::sqrt(P(ekf_index::kPosZ, ekf_index::kPosZ));
  out.sigma_yaw = std::sqrt(P(ekf_index::kYaw, ekf_index::kYaw));
  out.localized = filter.sigma_xy() <= params_.localized_sigma_xy;
}

void FrameOutput::fill_before_start(const OutputFrame& f, LocalizerFrameOutput& out,
                                    LocalizerCounters& counters) const {
  Mat4d pose = Mat4d::Identity();
  pose.topRightCorner<3, 1>() = f.gnss.enu;
  double road_z = 0.0;
  if (f.gnss.valid && f.map_ready &&
      road_height_near(f.map_points, f.gnss.enu, params_.road_height_radius, road_z, params_.road_height_min_points)) {
    pose(2, 3) = road_z;
    ++counters.road_height_outputs;
  }
  if (f.course_known) pose.topLeftCorner<3, 3>() = rot_z(f.course);
  if (f.has_candidate) pose = f.candidate.matrix();
  out.fused_pose = Pose3d(pose);
  out.fused_pose_ungated = out.fused_pose;
  out.sigma_x = out.sigma_y = f.gnss.valid ? f.gnss.sigma : 1e3;
  out.sigma_z = out.sigma_x;
  out.sigma_yaw = det::kPi;
  out.localized = false;
}

}  // namespace v2xloc
