#include "tools/eval/metrics.hpp"

#include <algorithm>

#include "host_sim/eval/trajectory.hpp"

namespace v2xloc::eval {
namespace {

struct Series {
  std::vector<Eigen::Vector3d> estimate, truth;
  void add(const Eigen::Vector3d& e, const Eigen::Vector3d& t) {
    estimate.push_back(e);
    truth.push_back(t);
  }
  double mean_error(bool align) const {
    if (estimate.empty()) return -1.0;  // printed as "n/a"
    const Eigen::Isometry3d a = align ? sim::umeyama_se3(estimate, truth) : Eigen::Isometry3d::Identity();
    double sum = 0.0;
    for (std::size_t i = 0; i < estimate.size(); ++i) sum += (a * estimate[i] - truth[i]).norm();
    return sum / static_cast<double>(estimate.size());
  }
};

Eigen::Vector3d position(const Mat4d& m) { return m.topRightCorner<3, 1>(); }
Eigen::Vector3d position(const Pose3d& p) { return p.translation(); }

}  // namespace

RowMetrics compute_metrics(const std::vector<FrameRecord>& records) {
  RowMetrics row;
  row.frames = static_cast<int>(records.size());
  Series slam, gps, gps_3d, reg, reg_valid, fused, fused_valid, fused_ungated, fused_lag;
  if (records.empty()) return row;
  const Eigen::Isometry3d anchor = records.front().truth *
                                   Eigen::Isometry3d(records.front().out.odometry_pose).inverse();
  for (const FrameRecord& r : records) {
    const Eigen::Vector3d truth = r.truth.translation();
    slam.add(anchor * position(r.out.odometry_pose), truth);
    if (r.has_gnss) {
      gps.add(Eigen::Vector3d(r.gnss_body.x(), r.gnss_body.y(), truth.z()), truth);
      gps_3d.add(r.gnss_body, truth);
    }
    const bool reg_ok = r.out.registration_attempted && r.out.registration_status == RegistrationStatus::kOk;
    if (reg_ok) {
      ++row.reg_ok_frames;
      reg.add(position(r.out.registration_pose), truth);
    }
    if (r.gate_valid && reg_ok) {
      ++row.valid_frames;
      reg_valid.add(position(r.out.registration_pose), truth);
      fused_valid.add(position(r.out.fused_pose), truth);
    }
    fused.add(position(r.out.fused_pose), truth);
    fused_ungated.add(position(r.out.fused_pose_ungated), truth);
    fused_lag.add(position(r.lagged_pose), truth);
    row.revised_frames += r.revised ? 1 : 0;
    const int index = static_cast<int>(&r - records.data());
    if (row.first_localized_frame < 0 && r.out.localized) row.first_localized_frame = index;
    if (row.first_initialized_frame < 0 && r.out.filter_initialized) row.first_initialized_frame = index;
    row.fused_max = std::max(row.fused_max, (position(r.out.fused_pose) - truth).norm());
  }
  for (bool align : {false, true}) {
    ColumnErrors& c = align ? row.aligned : row.unaligned;
    c.slam = slam.mean_error(align);
    c.gps = gps.mean_error(align);
    c.gps_3d = gps_3d.mean_error(align);
    c.reg = reg.mean_error(align);
    c.reg_valid = reg_valid.mean_error(align);
    c.fused = fused.mean_error(align);
    c.fused_valid = fused_valid.mean_error(align);
    c.fused_ungated = fused_ungated.mean_error(align);
    c.fused_lag = fused_lag.mean_error(align);
  }
  return row;
}

std::vector<double> fused_errors(const std::vector<FrameRecord>& records) {
  std::vector<double> e;
  e.reserve(records.size());
  for (const FrameRecord& r : records) e.push_back((position(r.out.fused_pose) - r.truth.translation()).norm());
  return e;
}

}  // namespace v2xloc::eval
