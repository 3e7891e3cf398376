#include "tools/eval/metrics.hpp"

#include <algorithm>
#include <cmath>

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

double yaw_of(const Eigen::Matrix3d& r) { return std::atan2(r(1, 0), r(0, 0)); }

// Mean over frame pairs ~dt apart (the later frame the first at or past dt) of the difference of
// the estimated and true displacements; frames without an estimate (has[i] false) are skipped.
double relative_error(const std::vector<FrameRecord>& records, const std::vector<Eigen::Vector3d>& estimate,
                      const std::vector<bool>& has, double dt) {
  double sum = 0.0;
  int n = 0;
  std::size_t j = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    while (j < records.size() && records[j].t < records[i].t + dt - 1e-6) ++j;
    if (j >= records.size()) break;
    if (!has[i] || !has[j] || records[j].t > records[i].t + 1.5 * dt) continue;
    const Eigen::Vector3d true_step = records[j].truth.translation() - records[i].truth.translation();
    sum += ((estimate[j] - estimate[i]) - true_step).norm();
    ++n;
  }
  return n > 0 ? sum / n : -1.0;
}

// The odometry is in its own frame: anchored at the truth of frame 0 (as the SLAM column).
RelativeErrors relative_errors(const std::vector<FrameRecord>& records, double dt) {
  std::vector<Eigen::Vector3d> fused, slam, gps;
  std::vector<bool> all(records.size(), true), with_fix;
  if (records.empty()) return {};
  const Eigen::Isometry3d anchor = records.front().truth *
                                   Eigen::Isometry3d(records.front().out.odometry_pose).inverse();
  for (const FrameRecord& r : records) {
    fused.push_back(position(r.out.fused_pose));
    slam.push_back(anchor * position(r.out.odometry_pose));
    gps.push_back(Eigen::Vector3d(r.gnss_body.x(), r.gnss_body.y(), r.truth.translation().z()));
    with_fix.push_back(r.has_gnss);
  }
  return {relative_error(records, fused, all, dt), relative_error(records, slam, all, dt),
          relative_error(records, gps, with_fix, dt)};
}

OffsetEstimate offset_of_valid_registrations(const std::vector<FrameRecord>& records) {
  OffsetEstimate o;
  std::vector<Eigen::Vector3d> d;
  std::vector<double> yaw;
  for (const FrameRecord& r : records) {
    if (!r.gate_valid || !r.out.registration_attempted || r.out.registration_status != RegistrationStatus::kOk) continue;
    d.push_back(position(r.out.registration_pose) - r.truth.translation());
    const Eigen::Matrix3d rot = r.out.registration_pose.linear();
    yaw.push_back(std::remainder(yaw_of(rot) - yaw_of(r.truth.linear()), 2.0 * M_PI) * 180.0 / M_PI);
  }
  o.frames = static_cast<int>(d.size());
  if (d.empty()) return o;
  for (std::size_t i = 0; i < d.size(); ++i) {
    o.mean += d[i];
    o.yaw_mean_deg += yaw[i];
  }
  o.mean /= static_cast<double>(d.size());
  o.yaw_mean_deg /= static_cast<double>(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    o.spread += (d[i] - o.mean).squaredNorm();
    o.yaw_spread_deg += (yaw[i] - o.yaw_mean_deg) * (yaw[i] - o.yaw_mean_deg);
  }
  o.spread = std::sqrt(o.spread / static_cast<double>(d.size()));
  o.yaw_spread_deg = std::sqrt(o.yaw_spread_deg / static_cast<double>(d.size()));
  return o;
}

}  // namespace

RowMetrics compute_metrics(const std::vector<FrameRecord>& all_records, double map_from) {
  RowMetrics row;
  const auto first = std::find_if(all_records.begin(), all_records.end(),
                                  [&](const FrameRecord& r) { return r.t >= map_from - 1e-9; });
  row.frames_before_map = static_cast<int>(first - all_records.begin());
  const std::vector<FrameRecord> records(first, all_records.end());
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
    const int index = static_cast<int>(&r - records.data()) + row.frames_before_map;
    if (row.first_localized_frame < 0 && r.out.localized) row.first_localized_frame = index;
    if (row.first_initialized_frame < 0 && r.out.filter_initialized) row.first_initialized_frame = index;
    row.fused_max = std::max(row.fused_max, (position(r.out.fused_pose) - truth).norm());
  }
  row.rpe_1s = relative_errors(records, 1.0);
  row.offset = offset_of_valid_registrations(records);
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
