#include "v2xloc/algo/registration/icp.hpp"

#include <Eigen/Cholesky>
#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/normal_equations.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/core/symmetric_eigen.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#include "v2xloc/algo/registration/lazy_normals.hpp"

namespace v2xloc {

double RobustKernel::weight(double residual) const {
  const double r = std::abs(residual);
  const double k = scale;
  switch (type) {
    case RobustKernelType::kNone: return 1.0;
    case RobustKernelType::kHuber: return r <= k ? 1.0 : k / r;
    case RobustKernelType::kTukey: {
      if (r > k) return 0.0;
      const double u = 1.0 - (r / k) * (r / k);
      return u * u;
    }
    case RobustKernelType::kCauchy: return 1.0 / (1.0 + (r / k) * (r / k));
    case RobustKernelType::kGemanMcClure: {
      const double k2 = k * k;
      const double d = k2 + r * r;
      return (k2 * k2) / (d * d);
    }
  }
  return 1.0;
}

namespace {

// Re-orthonormalises R (Gram-Schmidt on rows) so products of many updates stay in SO(3).
void orthonormalize_rows(Mat4d& t) {
  Vec3d x = t.block<1, 3>(0, 0).transpose();
  Vec3d y = t.block<1, 3>(1, 0).transpose();
  x /= x.norm();
  y -= x.dot(y) * x;
  y /= y.norm();
  const Vec3d z = x.cross(y);
  t.block<1, 3>(0, 0) = x.transpose();
  t.block<1, 3>(1, 0) = y.transpose();
  t.block<1, 3>(2, 0) = z.transpose();
}

// Eigenvalue spread of a symmetric positive semi-definite 6x6 after Jacobi (diagonal)
// preconditioning, S = D^-1/2 H D^-1/2 with D = diag(H): unit-free, so rotation (m^2) and
// translation (1) blocks compare fairly. Cyclic Jacobi rotations (Golub & Van Loan 8.5), fixed
// sweep count, sqrt only: deterministic on every ISA. Returns min/max eigenvalue (0 if singular).
double preconditioned_eigen_ratio(const Mat6d& h) {
  Mat6d s = h;
  for (int i = 0; i < 6; ++i) {
    if (!(h(i, i) > 0.0)) return 0.0;
  }
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) s(i, j) = h(i, j) / std::sqrt(h(i, i) * h(j, j));
  }
  for (int sweep = 0; sweep < 12; ++sweep) {
    double off = 0.0;
    for (int i = 0; i < 6; ++i) {
      for (int j = i + 1; j < 6; ++j) off += s(i, j) * s(i, j);
    }
    if (off < 1e-30) break;
    jacobi_sweep<double, 6>(s, static_cast<Mat6d*>(nullptr));
  }
  double lo = s(0, 0), hi = s(0, 0);
  for (int i = 1; i < 6; ++i) {
    lo = s(i, i) < lo ? s(i, i) : lo;
    hi = s(i, i) > hi ? s(i, i) : hi;
  }
  return hi > 0.0 && lo > 0.0 ? lo / hi : 0.0;
}

using Pass = IcpPass;
constexpr std::uint64_t kMapNormalWork = 45;  // a map normal computed on first use (~5,000 instructions)

double fitness(const Pass& p) { return p.valid_source > 0 ? double(p.inliers) / double(p.valid_source) : 0.0; }
double rmse(const Pass& p) { return p.inliers > 0 ? std::sqrt(p.squared_error_sum / double(p.inliers)) : 0.0; }
Mat6d information(const Pass& p) {
  Mat6d info = Mat6d::Zero();
  const double n = double(p.inliers);
  info.topLeftCorner<3, 3>() = p.qq_sum.trace() * Mat3d::Identity() - p.qq_sum;
  info.topRightCorner<3, 3>() = skew(p.q_sum);
  info.bottomLeftCorner<3, 3>() = skew(p.q_sum).transpose();
  info.bottomRightCorner<3, 3>() = n * Mat3d::Identity();
  return info;
}

// Smallest eigenvalue of the horizontal (tx, ty) block of the point-to-plane system over the
// trace of its translational block (closed form for a symmetric 2x2).
double horizontal_constraint(const Mat6d& h) {
  const double trace = h(3, 3) + h(4, 4) + h(5, 5);
  if (!(trace > 0.0)) return 0.0;
  const double mean = 0.5 * (h(3, 3) + h(4, 4)), half_diff = 0.5 * (h(3, 3) - h(4, 4));
  const double lambda_min = mean - std::sqrt(half_diff * half_diff + h(3, 4) * h(3, 4));
  return lambda_min > 0.0 ? lambda_min / trace : 0.0;
}

enum class PassMode { kEvaluateOnly, kPointToPoint, kPointToPlane };

// Float search bound that admits every point the double gate (d2 <= max_d2) accepts: the query
// is rounded to float (error ~ |pt| 2^-24 per axis) and the float distance adds a few ulps, so
// the radius is widened by 1e-5 (1 + |pt|_inf). The gate itself stays the double test below,
// so the matches are those of an unbounded nearest search followed by the gate.
float search_bound(const Vec3d& pt, double max_distance) {
  const double extent = std::abs(pt.x()) > std::abs(pt.y())
                            ? (std::abs(pt.x()) > std::abs(pt.z()) ? std::abs(pt.x()) : std::abs(pt.z()))
                            : (std::abs(pt.y()) > std::abs(pt.z()) ? std::abs(pt.y()) : std::abs(pt.z()));
  const double d = max_distance + 1e-5 * (1.0 + extent);
  return static_cast<float>(d * d);
}

// hints (optional, one per source point): last pass's match, seeds the search (same result).
// Accumulates source points [cursor, end), every stride-th, into pass until `work` reaches
// work_limit (one unit a point plus its query's node visits); true when the pass is complete.
bool run_pass(std::span<const Vec3f> source, const IcpTarget& target, const Mat4d& transform,
              double max_distance, const RobustKernel& kernel, PassMode mode, Pass& pass,
              std::span<std::uint32_t> hints, std::uint32_t& cursor, std::uint64_t& work,
              std::uint64_t work_limit, std::uint32_t stride = 1) {
  const Mat3d r = transform.topLeftCorner<3, 3>();
  const Vec3d t = transform.topRightCorner<3, 1>();
  const double max_d2 = max_distance * max_distance;
  const bool use_hints = hints.size() >= source.size();
  // Nothing within reach >= the gate: no correspondence, exactly what the tree would conclude
  // (1 mm slack: the grid is asked about the float-rounded query).
  constexpr double kVicinitySlack = 1e-3;
  const bool skip_empty = target.vicinity != nullptr && target.vicinity->ready() && target.vicinity->valid() &&
                          max_distance + kVicinitySlack <= target.vicinity->reach();
  for (; cursor < source.size(); cursor += stride) {
    if (work >= work_limit) return false;
    ++work;
    const std::size_t k = cursor;
    const Vec3f& pf = source[k];
    if (!pf.allFinite()) continue;
    ++pass.valid_source;
    const Vec3d p = pf.cast<double>();
    const Vec3d pt = r * p + t;
    Neighbor nn{};
    const Vec3f ptf = pt.cast<float>();
    if (skip_empty && target.vicinity->none_within_reach(ptf)) {
      if (use_hints) hints[k] = KdTree<Vec3f>::kNoHint;
      continue;
    }
    const std::uint32_t hint = use_hints ? hints[k] : KdTree<Vec3f>::kNoHint;
    const KdQueryResult qr = target.tree->nearest_within(ptf, search_bound(pt, max_distance), hint, nn);
    pass.node_visits += qr.node_visits;
    work += qr.node_visits;
    if (qr.visit_cap_hit) ++pass.search_truncated;
    if (use_hints) hints[k] = qr.count == 0 ? KdTree<Vec3f>::kNoHint : nn.index;
    if (qr.count == 0) continue;
    const Vec3d q = target.points[nn.index].cast<double>();
    const Vec3d e = pt - q;
    const double d2 = e.squaredNorm();
    if (!(d2 <= max_d2)) continue;
    ++pass.inliers;
    pass.squared_error_sum += d2;
    pass.qq_sum += q * q.transpose();
    pass.q_sum += q;
    if (mode == PassMode::kPointToPoint) {
      pass.kabsch.add(p, q, kernel.weight(std::sqrt(d2)));
    } else if (mode == PassMode::kPointToPlane) {
      Vec3f nf;
      if (target.lazy_normals != nullptr) {
        const std::uint32_t computed = target.lazy_normals->this_period().computed;
        nf = target.lazy_normals->get(nn.index);
        work += (target.lazy_normals->this_period().computed - computed) * kMapNormalWork;
      } else {
        nf = target.normals[nn.index];
      }
      const Vec3d n = nf.cast<double>();
      if (!n.allFinite()) continue;
      const double residual = n.dot(e);
      const double w = kernel.weight(residual);
      if (!(w > 0.0)) continue;
      Vec6d j;
      j.head<3>() = pt.cross(n);  // d(n.(exp(w^) p + v))/dw at 0 = (p x n)
      j.tail<3>() = n;
      add_weighted_outer_lower(pass.h, w, j);
      pass.b += (w * residual) * j;
    }
  }
  if (mode == PassMode::kPointToPlane) mirror_lower(pass.h);
  return true;
}

// A whole pass at once.
void run_pass(std::span<const Vec3f> source, const IcpTarget& target, const Mat4d& transform,
              double max_distance, const RobustKernel& kernel, PassMode mode, Pass& pass, std::uint32_t stride = 1) {
  std::uint32_t cursor = 0;
  std::uint64_t work = 0;
  run_pass(source, target, transform, max_distance, kernel, mode, pass, {}, cursor, work, ~std::uint64_t{0}, stride);
}

bool target_valid(const IcpTarget& target, bool need_normals) {
  if (target.tree == nullptr || target.points.empty()) return false;
  if (need_normals && target.normals.size() != target.points.size()) return false;
  return true;
}

void fill_from_pass(const Pass& pass, RegistrationResult& result) {
  result.fitness = fitness(pass);
  result.inlier_rmse = rmse(pass);
  result.inliers = pass.inliers;
  result.information = information(pass);
  result.horizontal_constraint = horizontal_constraint(pass.h);
}

std::uint32_t count_nonfinite(std::span<const Vec3f> cloud) {
  std::uint32_t n = 0;
  for (const Vec3f& p : cloud) n += p.allFinite() ? 0u : 1u;
  return n;
}

// The Gauss-Newton (point-to-plane) or Kabsch (point-to-point) step from one pass; false (and
// result.status set) when the system is degenerate.
bool update_transform(const Pass& pass, bool plane, const IcpParams& params, Mat4d& transform,
                      RegistrationResult& result) {
  Mat4d next = transform;
  if (plane) {
    if (!(preconditioned_eigen_ratio(pass.h) > params.min_eigenvalue_ratio)) {
      result.status = RegistrationStatus::kDegenerate;
      return false;
    }
    const Vec6d delta = pass.h.ldlt().solve(-pass.b);
    Mat4d update = Mat4d::Identity();
    update.topLeftCorner<3, 3>() = so3_exp_closed_form(delta.head<3>());
    update.topRightCorner<3, 1>() = delta.tail<3>();
    next = update * transform;
    orthonormalize_rows(next);
  } else {
    KabschParams kp;
    kp.min_singular_ratio = params.min_eigenvalue_ratio;
    if (pass.kabsch.solve(next, kp) != RegistrationStatus::kOk) {
      result.status = RegistrationStatus::kDegenerate;
      return false;
    }
  }
  if (!next.allFinite()) {
    result.status = RegistrationStatus::kDegenerate;
    return false;
  }
  transform = next;
  return true;
}

}  // namespace

RegistrationResult evaluate_registration(std::span<const Vec3f> source, const IcpTarget& target,
                                         const Mat4d& transform, double max_correspondence_distance,
                                         std::uint32_t stride) {
  RegistrationResult result;
  result.transform = transform;
  if (!target_valid(target, false) || !(max_correspondence_distance > 0.0) || !transform.allFinite() || stride == 0) {
    result.status = RegistrationStatus::kInvalidInput;
    return result;
  }
  result.nonfinite_dropped = count_nonfinite(source);
  Pass pass;
  run_pass(source, target, transform, max_correspondence_distance, RobustKernel{},
           PassMode::kEvaluateOnly, pass, stride);
  fill_from_pass(pass, result);
  result.search_truncated = pass.search_truncated;
  result.node_visits = pass.node_visits;
  result.status = pass.valid_source == 0   ? RegistrationStatus::kNotEnoughPoints
                  : pass.inliers == 0      ? RegistrationStatus::kNoCorrespondences
                                           : RegistrationStatus::kOk;
  return result;
}

RegistrationResult icp(std::span<const Vec3f> source, const IcpTarget& target, const Mat4d& initial,
                       const IcpParams& params, std::span<std::uint32_t> neighbor_scratch) {
  IcpRun run;
  icp_begin(run, source, target, initial, params, neighbor_scratch);
  const std::uint64_t work = params.max_work > 0 ? params.max_work : ~std::uint64_t{0};
  if (!icp_continue(run, source, target, params, ~std::uint32_t{0}, neighbor_scratch, work)) {
    run.result.status = RegistrationStatus::kDidNotConverge;  // out of work: as at the iteration cap
  }
  return run.result;
}

void icp_begin(IcpRun& run, std::span<const Vec3f> source, const IcpTarget& target, const Mat4d& initial,
               const IcpParams& params, std::span<std::uint32_t> neighbor_scratch) {
  run = IcpRun{};
  RegistrationResult& result = run.result;
  result.transform = initial;
  run.transform = initial;
  run.finished = true;
  const bool plane = params.method == IcpMethod::kPointToPlane;
  if (!target_valid(target, plane) || !(params.max_correspondence_distance > 0.0) ||
      !initial.allFinite() || !(params.kernel.scale > 0.0)) {
    result.status = RegistrationStatus::kInvalidInput;
    return;
  }
  result.nonfinite_dropped = count_nonfinite(source);
  if (source.size() - result.nonfinite_dropped < 3 || target.tree->size() < 3) {
    result.status = RegistrationStatus::kNotEnoughPoints;
    return;
  }
  if (neighbor_scratch.size() >= source.size()) {
    for (std::size_t k = 0; k < source.size(); ++k) neighbor_scratch[k] = KdTree<Vec3f>::kNoHint;
  }
  run.finished = false;
}

// One nearest-neighbour pass plus the update it implies: the body of the ICP loop.
bool icp_continue(IcpRun& run, std::span<const Vec3f> source, const IcpTarget& target,
                  const IcpParams& params, std::uint32_t max_passes,
                  std::span<std::uint32_t> neighbor_scratch, std::uint64_t max_work) {
  RegistrationResult& result = run.result;
  const std::uint64_t work_limit = max_work > ~std::uint64_t{0} - run.work ? ~std::uint64_t{0} : run.work + max_work;
  const bool plane = params.method == IcpMethod::kPointToPlane;
  const std::uint32_t max_iterations =
      params.criteria.max_iterations < config::kIcpMaxIterations ? params.criteria.max_iterations
                                                                 : config::kIcpMaxIterations;
  const PassMode mode = plane ? PassMode::kPointToPlane : PassMode::kPointToPoint;
  for (std::uint32_t passes = 0; !run.finished && passes < max_passes; ++passes) {
    if (!run.in_pass) {
      run.pass = Pass{};
      run.cursor = 0;
      run.in_pass = true;
    }
    if (!run_pass(source, target, run.transform, params.max_correspondence_distance, params.kernel, mode, run.pass,
                  neighbor_scratch, run.cursor, run.work, work_limit)) {
      return false;  // out of work inside the pass: it resumes at run.cursor
    }
    run.in_pass = false;
    const Pass& pass = run.pass;
    const std::uint32_t k = run.passes++;
    result.search_truncated += pass.search_truncated;
    result.node_visits += pass.node_visits;
    result.transform = run.transform;
    fill_from_pass(pass, result);
    result.iterations = k;
    run.finished = true;  // unless the loop goes on below
    if (pass.inliers == 0) {
      result.status = RegistrationStatus::kNoCorrespondences;
      return true;
    }
    if (k > 0 && std::abs(run.prev_fitness - fitness(pass)) < params.criteria.relative_fitness &&
        std::abs(run.prev_rmse - rmse(pass)) < params.criteria.relative_rmse) {
      result.converged = true;
      result.status = RegistrationStatus::kOk;
      return true;
    }
    if (k == max_iterations) {
      result.status = RegistrationStatus::kOk;
      return true;
    }
    run.prev_fitness = fitness(pass);
    run.prev_rmse = rmse(pass);
    if (!update_transform(pass, plane, params, run.transform, result)) return true;
    run.finished = false;
  }
  return run.finished;
}

}  // namespace v2xloc
