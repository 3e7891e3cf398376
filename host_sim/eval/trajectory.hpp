// Trajectories for evaluation: TUM files (`t x y z qx qy qz qw`), time association, SE(3)
// Umeyama alignment (as evo's APE with --align) and absolute position error statistics.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct StampedPose {
  double t = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

using StampedTrajectory = std::vector<StampedPose>;

// Reads a TUM trajectory; comment lines (#) and blank lines are skipped. Returns false with a
// message (file and line) on unreadable files or malformed lines.
bool read_tum(const std::string& path, StampedTrajectory& out, std::string& error);
bool write_tum(const std::string& path, const StampedTrajectory& trajectory, std::string& error);

// Pairs of indices (estimate, reference) whose stamps differ by at most max_dt seconds; each
// reference pose is used at most once, both sequences must be sorted by time.
std::vector<std::pair<std::size_t, std::size_t>> associate(const StampedTrajectory& estimate,
                                                           const StampedTrajectory& reference,
                                                           double max_dt);

// Rigid transform T minimising sum |T * a_i - b_i|^2 (Umeyama 1991, scale fixed to 1).
// Needs >= 3 non-collinear points; returns identity otherwise.
Eigen::Isometry3d umeyama_se3(const std::vector<Eigen::Vector3d>& a,
                              const std::vector<Eigen::Vector3d>& b);

struct ErrorStats {
  std::size_t count = 0;
  double mean = 0.0;
  double rmse = 0.0;
  double median = 0.0;
  double max = 0.0;
};

ErrorStats error_stats(std::vector<double> errors);

// Absolute position error of matched poses; with align = true the estimate is first moved by
// the Umeyama SE(3) transform onto the reference (the paper's "aligned" numbers).
ErrorStats absolute_position_error(const StampedTrajectory& estimate, const StampedTrajectory& reference,
                                   bool align, double max_dt = 0.005,
                                   std::vector<double>* per_pose_errors = nullptr);

}  // namespace v2xloc::sim
