#include "v2xloc/algo/registration/ransac.hpp"

#include <cmath>

#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#include "v2xloc/algo/core/prng.hpp"

namespace v2xloc {
namespace {

// Natural logarithm from +,-,*,/ only (libm's log may differ in the last ulp between ISAs, and
// the adaptive bound decides which samples are drawn): x = m 2^e with m in [sqrt(1/2), sqrt(2)),
// ln m = 2 atanh(s), s = (m - 1) / (m + 1), |s| < 0.172, series to s^41 (error < 1e-17).
double deterministic_log(double x) {
  if (!(x > 0.0)) return -HUGE_VAL;
  int e = 0;
  double m = std::frexp(x, &e);  // exact: m in [0.5, 1)
  if (m < 0.70710678118654752440) {
    m *= 2.0;
    --e;
  }
  const double s = (m - 1.0) / (m + 1.0);
  const double s2 = s * s;
  double series = 0.0;
  for (int k = 20; k >= 0; --k) series = series * s2 + 1.0 / (2.0 * k + 1.0);
  constexpr double kLn2 = 0.69314718055994530942;
  return static_cast<double>(e) * kLn2 + 2.0 * s * series;
}

// Open3D's bound on the samples needed to draw one all-inlier triple with the given confidence.
std::uint32_t adaptive_iteration_bound(double inlier_ratio, double confidence, std::uint32_t cap) {
  const double p = inlier_ratio * inlier_ratio * inlier_ratio;
  if (p >= 1.0) return 1;
  if (!(p > 0.0)) return cap;
  const double k = deterministic_log(1.0 - confidence) / deterministic_log(1.0 - p);
  if (!(k < static_cast<double>(cap))) return cap;
  return static_cast<std::uint32_t>(std::ceil(k));
}

struct Score {
  std::uint32_t inliers = 0;
  double squared_error_sum = 0.0;
  double fitness(std::size_t n) const { return n > 0 ? double(inliers) / double(n) : 0.0; }
  double rmse() const { return inliers > 0 ? std::sqrt(squared_error_sum / inliers) : 0.0; }
  // Open3D IsBetterRANSACThan: higher fitness, ties by lower RMSE.
  bool better_than(const Score& other) const {
    if (inliers != other.inliers) return inliers > other.inliers;
    return inliers > 0 && rmse() < other.rmse();
  }
};

class CorrespondenceSet {
 public:
  CorrespondenceSet(std::span<const Vec3f> source, std::span<const Vec3f> target,
                    std::span<const Correspondence> corr)
      : source_(source), target_(target), corr_(corr) {}

  bool valid(std::size_t i) const {
    const Correspondence& c = corr_[i];
    return c.source < source_.size() && c.target < target_.size() &&
           source_[c.source].allFinite() && target_[c.target].allFinite();
  }
  Vec3d source(std::size_t i) const { return source_[corr_[i].source].cast<double>(); }
  Vec3d target(std::size_t i) const { return target_[corr_[i].target].cast<double>(); }
  std::size_t size() const { return corr_.size(); }

  // Correspondences within max distance under T (invalid ones never count).
  Score score(const Mat4d& t, double max_d2, KabschAccumulator* refit) const {
    const Mat3d r = t.topLeftCorner<3, 3>();
    const Vec3d tr = t.topRightCorner<3, 1>();
    Score s;
    for (std::size_t i = 0; i < corr_.size(); ++i) {
      if (!valid(i)) continue;
      const Vec3d p = source(i);
      const Vec3d q = target(i);
      const double d2 = (r * p + tr - q).squaredNorm();
      if (d2 < max_d2) {
        ++s.inliers;
        s.squared_error_sum += d2;
        if (refit != nullptr) refit->add(p, q);
      }
    }
    return s;
  }

 private:
  std::span<const Vec3f> source_;
  std::span<const Vec3f> target_;
  std::span<const Correspondence> corr_;
};

bool within_prior(const Mat4d& t, const RansacPosePrior& prior) {
  const double dx = t(0, 3) - prior.center.x(), dy = t(1, 3) - prior.center.y();
  if (dx * dx + dy * dy > prior.max_horizontal * prior.max_horizontal) return false;
  if (std::abs(t(2, 3) - prior.center.z()) > prior.max_vertical) return false;
  // cos(tilt) = (R z) . z = R(2, 2).
  return t(2, 2) >= det::cos(prior.max_tilt);
}

bool edge_lengths_similar(const Vec3d (&ps)[3], const Vec3d (&pt)[3], double similarity) {
  for (int i = 0; i < 3; ++i) {
    for (int j = i + 1; j < 3; ++j) {
      const double ds = (ps[i] - ps[j]).norm();
      const double dt = (pt[i] - pt[j]).norm();
      if (ds < similarity * dt || dt < similarity * ds) return false;
    }
  }
  return true;
}

// One drawn triple's hypothesis, or why there is none (counted in the result).
enum class Draw : std::uint8_t { kHypothesis, kDegenerate, kEdgeLength, kDistance, kPrior };

// Three distinct indices (rejection keeps the draw uniform over distinct triples), then the
// cheap checks before a hypothesis is scored: valid points, similar edge lengths, a Kabsch fit
// that brings the three pairs within the distance, the pose prior.
Draw draw_hypothesis(const CorrespondenceSet& set, const RansacParams& params, std::uint32_t n, Pcg32& rng,
                     Mat4d& t) {
  std::uint32_t idx[3];
  idx[0] = rng.uniform_below(n);
  do { idx[1] = rng.uniform_below(n); } while (idx[1] == idx[0]);
  do { idx[2] = rng.uniform_below(n); } while (idx[2] == idx[0] || idx[2] == idx[1]);
  if (!set.valid(idx[0]) || !set.valid(idx[1]) || !set.valid(idx[2])) return Draw::kDegenerate;
  Vec3d ps[3], pt[3];
  for (int k = 0; k < 3; ++k) {
    ps[k] = set.source(idx[k]);
    pt[k] = set.target(idx[k]);
  }
  if (params.edge_length_similarity > 0.0 && !edge_lengths_similar(ps, pt, params.edge_length_similarity)) {
    return Draw::kEdgeLength;
  }
  KabschAccumulator acc;
  for (int k = 0; k < 3; ++k) acc.add(ps[k], pt[k]);
  if (acc.solve(t) != RegistrationStatus::kOk) return Draw::kDegenerate;
  if (params.distance_check_threshold >= 0.0) {
    const double limit = params.distance_check_threshold > 0.0 ? params.distance_check_threshold
                                                               : params.max_correspondence_distance;
    bool close = true;
    for (int k = 0; k < 3 && close; ++k) {
      const Vec3d e = t.topLeftCorner<3, 3>() * ps[k] + t.topRightCorner<3, 1>() - pt[k];
      close = e.norm() <= limit;
    }
    if (!close) return Draw::kDistance;
  }
  if (params.prior.enabled && !within_prior(t, params.prior)) return Draw::kPrior;
  return Draw::kHypothesis;
}

void count_rejection(Draw d, RansacResult& out) {
  switch (d) {
    case Draw::kDegenerate: ++out.degenerate_samples; break;
    case Draw::kEdgeLength: ++out.rejected_edge_length; break;
    case Draw::kDistance: ++out.rejected_distance; break;
    case Draw::kPrior: ++out.rejected_prior; break;
    case Draw::kHypothesis: break;
  }
}

// Refit on all inliers while that does not lose inliers (least squares over the consensus set).
void refit_on_inliers(const CorrespondenceSet& set, double max_d2, std::uint32_t rounds, Score& best,
                      Mat4d& best_transform) {
  for (std::uint32_t round = 0; round < rounds; ++round) {
    KabschAccumulator acc;
    set.score(best_transform, max_d2, &acc);
    Mat4d refit;
    if (acc.solve(refit) != RegistrationStatus::kOk) break;
    const Score s = set.score(refit, max_d2, nullptr);
    if (s.inliers < best.inliers) break;
    const bool grew = s.inliers > best.inliers;
    best = s;
    best_transform = refit;
    if (!grew) break;
  }
}

// The consensus search: the best-scoring hypothesis until the adaptive bound (Open3D's
// confidence rule), the iteration cap or the validation cap stops it.
struct Consensus {
  Score best;
  Mat4d transform = Mat4d::Identity();
  bool found = false;
  std::uint32_t iterations = 0;
  std::uint32_t bound = 0;
};

Consensus search_consensus(const CorrespondenceSet& set, std::size_t usable, const RansacParams& params,
                           RansacResult& out) {
  const std::uint32_t max_iterations = params.criteria.max_iterations < config::kRansacMaxIterations
                                           ? params.criteria.max_iterations
                                           : config::kRansacMaxIterations;
  const std::uint32_t max_validations = params.criteria.max_validations < config::kRansacMaxValidations
                                            ? params.criteria.max_validations
                                            : config::kRansacMaxValidations;
  const double max_d2 = params.max_correspondence_distance * params.max_correspondence_distance;
  const auto n = static_cast<std::uint32_t>(set.size());
  Pcg32 rng(params.seed);
  Consensus c;
  c.bound = max_iterations;
  std::uint32_t itr = 0;
  for (; itr < max_iterations && itr < c.bound && out.validations < max_validations; ++itr) {
    Mat4d t;
    const Draw d = draw_hypothesis(set, params, n, rng, t);
    if (d != Draw::kHypothesis) {
      count_rejection(d, out);
      continue;
    }
    ++out.validations;
    const Score s = set.score(t, max_d2, nullptr);
    if (!s.better_than(c.best)) continue;
    c.best = s;
    c.transform = t;
    c.found = true;
    const std::uint32_t b = adaptive_iteration_bound(c.best.fitness(usable), params.criteria.confidence, max_iterations);
    if (b < c.bound) c.bound = b;
  }
  c.iterations = itr;
  return c;
}

}  // namespace

RansacResult ransac(std::span<const Vec3f> source, std::span<const Vec3f> target,
                    std::span<const Correspondence> correspondences,
                    const KdTree<Vec3f>& target_tree, const RansacParams& params) {
  RansacResult out;
  RegistrationResult& reg = out.registration;
  if (!(params.max_correspondence_distance > 0.0) || !(params.criteria.confidence > 0.0) ||
      !(params.criteria.confidence < 1.0) || correspondences.size() > 0xFFFFFFFFu) {
    reg.status = RegistrationStatus::kInvalidInput;
    return out;
  }
  const CorrespondenceSet set(source, target, correspondences);
  std::size_t usable = 0;
  for (std::size_t i = 0; i < set.size(); ++i) usable += set.valid(i) ? 1 : 0;
  out.invalid_correspondences = static_cast<std::uint32_t>(set.size() - usable);
  if (usable < 3) {
    reg.status = RegistrationStatus::kNoCorrespondences;
    return out;
  }
  Consensus c = search_consensus(set, usable, params, out);
  reg.iterations = c.iterations;
  out.adaptive_bound = c.bound;
  if (!c.found || c.best.inliers < 3) {
    reg.status = RegistrationStatus::kDidNotConverge;
    return out;
  }
  out.correspondence_fitness = c.best.fitness(usable);
  const double max_d2 = params.max_correspondence_distance * params.max_correspondence_distance;
  refit_on_inliers(set, max_d2, params.refit_rounds, c.best, c.transform);
  out.correspondence_inliers = c.best.inliers;

  IcpTarget view;
  view.points = target;
  view.tree = &target_tree;
  reg = evaluate_registration(source, view, c.transform, params.max_correspondence_distance);
  reg.iterations = c.iterations;
  reg.converged = c.iterations >= c.bound;  // the confidence bound (not a cap) ended the search
  return out;
}

}  // namespace v2xloc
