#include "host_sim/eval/trajectory.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace v2xloc::sim {

bool read_tum(const std::string& path, StampedTrajectory& out, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  out.clear();
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    StampedPose pose;
    double qx, qy, qz, qw;
    if (!(fields >> pose.t >> pose.position.x() >> pose.position.y() >> pose.position.z() >> qx >>
          qy >> qz >> qw)) {
      error = path + ":" + std::to_string(line_no) + ": expected 't x y z qx qy qz qw'";
      return false;
    }
    pose.orientation = Eigen::Quaterniond(qw, qx, qy, qz);
    const double norm = pose.orientation.norm();
    if (!std::isfinite(norm) || norm < 1e-9 || !pose.position.allFinite() || !std::isfinite(pose.t)) {
      error = path + ":" + std::to_string(line_no) + ": non-finite pose or zero quaternion";
      return false;
    }
    pose.orientation.normalize();
    out.push_back(pose);
  }
  return true;
}

bool write_tum(const std::string& path, const StampedTrajectory& trajectory, std::string& error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    error = "cannot write " + path;
    return false;
  }
  for (const auto& p : trajectory) {
    const auto& q = p.orientation;
    std::fprintf(f, "%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", p.t, p.position.x(), p.position.y(),
                 p.position.z(), q.x(), q.y(), q.z(), q.w());
  }
  const bool ok = std::fclose(f) == 0;
  if (!ok) error = "error closing " + path;
  return ok;
}

std::vector<std::pair<std::size_t, std::size_t>> associate(const StampedTrajectory& estimate,
                                                           const StampedTrajectory& reference,
                                                           double max_dt) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::size_t j = 0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const double t = estimate[i].t;
    while (j + 1 < reference.size() && reference[j + 1].t <= t) ++j;
    // Candidates j and j+1 bracket t; take the closer one.
    std::size_t best = j;
    if (j + 1 < reference.size() &&
        std::abs(reference[j + 1].t - t) < std::abs(reference[j].t - t)) {
      best = j + 1;
    }
    if (best < reference.size() && std::abs(reference[best].t - t) <= max_dt &&
        (pairs.empty() || pairs.back().second != best)) {
      pairs.emplace_back(i, best);
    }
  }
  return pairs;
}

Eigen::Isometry3d umeyama_se3(const std::vector<Eigen::Vector3d>& a,
                              const std::vector<Eigen::Vector3d>& b) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  const std::size_t n = std::min(a.size(), b.size());
  if (n < 3) return transform;
  Eigen::Vector3d mean_a = Eigen::Vector3d::Zero(), mean_b = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mean_a += a[i];
    mean_b += b[i];
  }
  mean_a /= static_cast<double>(n);
  mean_b /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) cov += (b[i] - mean_b) * (a[i] - mean_a).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s(2, 2) = -1.0;
  const Eigen::Matrix3d r = svd.matrixU() * s * svd.matrixV().transpose();
  transform.linear() = r;
  transform.translation() = mean_b - r * mean_a;
  return transform;
}

ErrorStats error_stats(std::vector<double> errors) {
  ErrorStats stats;
  stats.count = errors.size();
  if (errors.empty()) return stats;
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    stats.max = std::max(stats.max, e);
  }
  stats.mean = sum / static_cast<double>(errors.size());
  stats.rmse = std::sqrt(sum_sq / static_cast<double>(errors.size()));
  std::sort(errors.begin(), errors.end());
  const std::size_t mid = errors.size() / 2;
  stats.median = errors.size() % 2 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  return stats;
}

ErrorStats absolute_position_error(const StampedTrajectory& estimate, const StampedTrajectory& reference,
                                   bool align, double max_dt, std::vector<double>* per_pose_errors) {
  const auto pairs = associate(estimate, reference, max_dt);
  std::vector<Eigen::Vector3d> est, ref;
  est.reserve(pairs.size());
  ref.reserve(pairs.size());
  for (const auto& [i, j] : pairs) {
    est.push_back(estimate[i].position);
    ref.push_back(reference[j].position);
  }
  const Eigen::Isometry3d t = align ? umeyama_se3(est, ref) : Eigen::Isometry3d::Identity();
  std::vector<double> errors;
  errors.reserve(est.size());
  for (std::size_t k = 0; k < est.size(); ++k) errors.push_back((t * est[k] - ref[k]).norm());
  if (per_pose_errors) *per_pose_errors = errors;
  return error_stats(std::move(errors));
}

}  // namespace v2xloc::sim
