#include "v2xloc/algo/registration/fpfh.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/finite.hpp"

namespace v2xloc {
namespace {

constexpr int kBinsPerFeature = 11;

// Open3D's bin index: floor, then clamp to [0, 10]. The argument is finite here.
int clamp_bin(double x) {
  const double f = std::floor(x);
  if (f < 0.0) return 0;
  if (f >= kBinsPerFeature) return kBinsPerFeature - 1;
  return static_cast<int>(f);
}

}  // namespace

namespace {

// The pair feature before the angle: theta = atan2(theta_y, theta_x).
struct PairComponents {
  double theta_y, theta_x, f1, f2, distance;
  bool zero;  // Open3D's all-zero feature (coincident points or normal parallel to the line)
};

PairComponents pair_components(const Vec3d& p1, const Vec3d& n1, const Vec3d& p2,
                               const Vec3d& n2) {
  PairComponents c{0.0, 0.0, 0.0, 0.0, 0.0, true};
  Vec3d d = p2 - p1;
  const double distance = d.norm();
  if (distance == 0.0) return c;
  const double cos1 = n1.dot(d) / distance;
  const double cos2 = n2.dot(d) / distance;
  // Source = the point whose normal is closer to the line (Rusu 2009, Sec. III; Open3D compares
  // acos(|cos|), i.e. swaps when |cos1| < |cos2|).
  const Vec3d* u = &n1;
  const Vec3d* other = &n2;
  double f2 = cos1;
  if (std::abs(cos1) < std::abs(cos2)) {
    u = &n2;
    other = &n1;
    d = -d;
    f2 = -cos2;
  }
  Vec3d v = d.cross(*u);
  const double v_norm = v.norm();
  if (v_norm == 0.0) return c;
  v /= v_norm;
  const Vec3d w = u->cross(v);
  c.theta_y = w.dot(*other);
  c.theta_x = u->dot(*other);
  c.f1 = v.dot(*other);
  c.f2 = f2;
  c.distance = distance;
  c.zero = false;
  return c;
}

// cos, sin of k pi / 11 for k = 1, 3, 5, 7, 9: the theta bin boundaries -pi + 2 pi b / 11.
constexpr double kBoundary[5][2] = {
    {0.95949297361449737, 0.28173255684142967}, {0.6548607339452851, 0.75574957435425827},
    {0.14231483827328512, 0.98982144188093268}, {-0.41541501300188632, 0.90963199535451844},
    {-0.84125353283118109, 0.54064081745559778}};

// Bin of theta = atan2(y, x) in 11 bins over [-pi, pi] without evaluating atan2: count the
// boundary directions the vector lies counter-clockwise of (sign of a 2-D cross product).
// Same result as floor(11 (theta + pi) / 2 pi) except within rounding of a boundary.
int theta_bin(double y, double x) {
  if (x == 0.0 && y == 0.0) {
    return clamp_bin(11.0 * (det::atan2(y, x) + det::kPi) / (2.0 * det::kPi));
  }
  int bin = 0;
  if (!std::signbit(y)) {  // theta in [0, pi]: boundaries k pi / 11
    bin = 5;
    for (const auto& b : kBoundary) bin += (b[0] * y - b[1] * x >= 0.0) ? 1 : 0;
  } else {  // theta in [-pi, 0): boundaries -k pi / 11
    for (const auto& b : kBoundary) bin += (b[0] * y + b[1] * x >= 0.0) ? 1 : 0;
  }
  return bin;
}

}  // namespace

PairFeature fpfh_pair_feature(const Vec3d& p1, const Vec3d& n1, const Vec3d& p2,
                              const Vec3d& n2) {
  const PairComponents c = pair_components(p1, n1, p2, n2);
  if (c.zero) return {0.0, 0.0, 0.0, 0.0};
  return {det::atan2(c.theta_y, c.theta_x), c.f1, c.f2, c.distance};
}

FpfhResult compute_fpfh(const KdTree<Vec3f>& tree, std::span<const Vec3f> normals,
                        const FpfhParams& params, std::span<Feature33> spfh_scratch,
                        std::span<Feature33> features) {
  return compute_fpfh(KdNeighborhoods(tree), normals, params, spfh_scratch, features);
}

namespace {

// Pass 1: the SPFH of point i (its pairs with each neighbour, binned).
void point_spfh(const KdNeighborhoods& neighborhoods, std::span<const Vec3f> normals, const FpfhParams& params,
                std::size_t max_nn, std::size_t i, std::span<Neighbor> buffer, Feature33& spfh, FpfhResult& r) {
  const std::span<const Vec3f> points = neighborhoods.tree().points();
  spfh.setZero();
  if (!is_finite_point(points[i])) {
    ++r.non_finite_points;
    return;
  }
  const KdQueryResult kr = neighborhoods.get(i, params.radius, max_nn, buffer);
  r.search.add(kr);
  if (kr.count <= 1) return;
  const double increment = 100.0 / static_cast<double>(kr.count - 1);
  double hist[kFpfhBins] = {};
  const Vec3d p1 = points[i].cast<double>();
  const Vec3d n1 = normals[i].cast<double>();
  for (std::uint32_t k = 1; k < kr.count; ++k) {  // entry 0 is the point itself
    const std::uint32_t j = buffer[k].index;
    const PairComponents c = pair_components(p1, n1, points[j].cast<double>(), normals[j].cast<double>());
    if (!std::isfinite(c.theta_y) || !std::isfinite(c.theta_x) || !std::isfinite(c.f1) || !std::isfinite(c.f2)) {
      ++r.non_finite_pairs;
      continue;
    }
    // Open3D's operation order for the alpha/phi bins so boundaries fall identically.
    hist[theta_bin(c.theta_y, c.theta_x)] += increment;
    hist[kBinsPerFeature + clamp_bin(11.0 * (c.f1 + 1.0) * 0.5)] += increment;
    hist[2 * kBinsPerFeature + clamp_bin(11.0 * (c.f2 + 1.0) * 0.5)] += increment;
  }
  for (int b = 0; b < kFpfhBins; ++b) spfh[b] = static_cast<float>(hist[b]);
}

// Pass 2: FPFH of point i = own SPFH + normalised inverse-squared-distance weighted neighbour SPFHs.
void point_fpfh(const KdNeighborhoods& neighborhoods, const FpfhParams& params, std::size_t max_nn,
                std::size_t i, std::span<Neighbor> buffer, std::span<const Feature33> spfh_scratch,
                Feature33& out, FpfhResult& r) {
  out.setZero();
  if (!is_finite_point(neighborhoods.tree().points()[i])) return;
  const KdQueryResult kr = neighborhoods.get(i, params.radius, max_nn, buffer);
  r.search.add(kr);
  if (kr.count <= 1) {
    ++r.isolated;
    return;
  }
  double acc[kFpfhBins] = {};
  for (std::uint32_t k = 1; k < kr.count; ++k) {
    const double dist2 = buffer[k].squared_distance;
    if (dist2 == 0.0) continue;
    const double weight = 1.0 / dist2;  // one division, not 33 (<= 1 ulp from Open3D's s/d)
    const Feature33& s = spfh_scratch[buffer[k].index];
    // 33 independent accumulators (no loop-carried chain through a block sum: Open3D sums
    // the block totals alongside; summing acc afterwards differs only in rounding).
    // 32 + 1: a trip count that is a multiple of the vector width lets -O2 vectorise the loop
    // (element-wise, so the bits are the same as the scalar loop).
    for (int b = 0; b < 32; ++b) acc[b] += static_cast<double>(s[b]) * weight;
    acc[32] += static_cast<double>(s[32]) * weight;
  }
  double block_sum[3] = {0.0, 0.0, 0.0};
  for (int block = 0; block < 3; ++block) {
    double sum = 0.0;
    for (int b = 0; b < kBinsPerFeature; ++b) sum += acc[block * kBinsPerFeature + b];
    block_sum[block] = sum != 0.0 ? 100.0 / sum : 0.0;
  }
  const Feature33& own = spfh_scratch[i];
  for (int b = 0; b < kFpfhBins; ++b) {
    out[b] = static_cast<float>(acc[b] * block_sum[b / kBinsPerFeature] + static_cast<double>(own[b]));
  }
}

}  // namespace

FpfhResult compute_fpfh(const KdNeighborhoods& neighborhoods, std::span<const Vec3f> normals,
                        const FpfhParams& params, std::span<Feature33> spfh_scratch,
                        std::span<Feature33> features) {
  FpfhResult r;
  const KdTree<Vec3f>& tree = neighborhoods.tree();
  const std::size_t n = tree.points().size();
  if (tree.empty()) {
    r.status = FpfhStatus::kEmptyTree;
    return r;
  }
  if (!std::isfinite(params.radius) || !(params.radius > 0.0f) || params.max_nn < 2 ||
      normals.size() < n || spfh_scratch.size() < n || features.size() < n) {
    r.status = FpfhStatus::kInvalidParams;
    return r;
  }
  std::size_t max_nn = params.max_nn;
  if (max_nn > config::kMaxNeighbors) {
    max_nn = config::kMaxNeighbors;
    r.max_nn_clamped = 1;
  }
  Neighbor neighbors[config::kMaxNeighbors];
  const std::span<Neighbor> buffer(neighbors, max_nn);
  for (std::size_t i = 0; i < n; ++i) point_spfh(neighborhoods, normals, params, max_nn, i, buffer, spfh_scratch[i], r);
  for (std::size_t i = 0; i < n; ++i) {
    point_fpfh(neighborhoods, params, max_nn, i, buffer, spfh_scratch, features[i], r);
  }
  r.points = static_cast<std::uint32_t>(n);
  r.status = FpfhStatus::kOk;
  return r;
}

}  // namespace v2xloc
