// THE agreement test with Open3D 0.16 (fixture from tools/fixtures/make_fpfh_fixture.py):
// normals equal up to sign, FPFH (on Open3D's normals) within 1 % L1 for >= 99 % of points.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "v2xloc/algo/registration/fpfh.hpp"
#include "v2xloc/algo/registration/normals.hpp"

namespace v2xloc {
namespace {

struct Fixture {
  float voxel = 0, normal_radius = 0, fpfh_radius = 0;
  std::uint32_t normal_max_nn = 0, fpfh_max_nn = 0;
  Vec3f viewpoint = Vec3f::Zero();
  std::vector<Vec3f> points, normals;
  std::vector<Feature33> fpfh;
};

bool load(const char* path, Fixture& f) {
  std::FILE* file = std::fopen(path, "rb");
  if (file == nullptr) return false;
  char magic[8];
  std::uint32_t n = 0;
  bool ok = std::fread(magic, 1, 8, file) == 8 && std::memcmp(magic, "V2XFPFH1", 8) == 0 &&
            std::fread(&n, 4, 1, file) == 1 && std::fread(&f.voxel, 4, 1, file) == 1 &&
            std::fread(&f.normal_radius, 4, 1, file) == 1 &&
            std::fread(&f.normal_max_nn, 4, 1, file) == 1 &&
            std::fread(&f.fpfh_radius, 4, 1, file) == 1 &&
            std::fread(&f.fpfh_max_nn, 4, 1, file) == 1 &&
            std::fread(f.viewpoint.data(), 4, 3, file) == 3;
  std::vector<float> row(39);
  for (std::uint32_t i = 0; ok && i < n; ++i) {
    ok = std::fread(row.data(), 4, 39, file) == 39;
    f.points.emplace_back(row[0], row[1], row[2]);
    f.normals.emplace_back(row[3], row[4], row[5]);
    f.fpfh.emplace_back(Eigen::Map<const Feature33>(row.data() + 6));
  }
  std::fclose(file);
  return ok;
}

constexpr std::size_t kMax = 8192;
static KdTreeStorage<Vec3f, kMax> tree;
static Vec3f normals[kMax];
static Feature33 spfh[kMax];
static Feature33 features[kMax];

class FpfhOpen3d : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* path = V2XLOC_SOURCE_DIR "/tests/data/fpfh_outdoor_source_v05.bin";
    ASSERT_TRUE(load(path, fx)) << path;
    ASSERT_LE(fx.points.size(), kMax);
    ASSERT_EQ(tree.build(fx.points).status, KdBuildStatus::kOk);
  }
  Fixture fx;
};

TEST_F(FpfhOpen3d, NormalsMatchUpToSign) {
  NormalParams np;
  np.radius = fx.normal_radius;
  np.max_nn = fx.normal_max_nn;
  np.viewpoint = fx.viewpoint;
  const NormalsResult r = estimate_normals(tree.tree, np, normals);
  ASSERT_EQ(r.status, NormalsStatus::kOk);
  std::size_t agree = 0, same_sign = 0;
  double worst = 1.0;
  for (std::size_t i = 0; i < fx.points.size(); ++i) {
    const double d = normals[i].cast<double>().dot(fx.normals[i].cast<double>());
    worst = std::min(worst, std::abs(d));
    agree += std::abs(d) > 0.999 ? 1 : 0;
    same_sign += d > 0.999 ? 1 : 0;
  }
  const double frac = double(agree) / double(fx.points.size());
  std::printf("normals: %zu points, |dot|>0.999: %.4f %%, same orientation: %.4f %%, "
              "worst |dot| %.6f, few-neighbour %u, collinear %u\n",
              fx.points.size(), 100.0 * frac, 100.0 * double(same_sign) / double(fx.points.size()),
              worst, r.few_neighbors, r.collinear);
  EXPECT_GE(frac, 0.99);
}

TEST_F(FpfhOpen3d, FpfhMatchesOpen3dOnSameNormals) {
  FpfhParams fp;
  fp.radius = fx.fpfh_radius;
  fp.max_nn = fx.fpfh_max_nn;
  const FpfhResult r = compute_fpfh(tree.tree, fx.normals, fp, spfh, features);
  ASSERT_EQ(r.status, FpfhStatus::kOk);
  std::size_t agree = 0;
  double worst = 0.0, sum_rel = 0.0;
  for (std::size_t i = 0; i < fx.points.size(); ++i) {
    double diff = 0.0, norm = 0.0;
    for (int b = 0; b < kFpfhBins; ++b) {
      diff += std::abs(double(features[i][b]) - double(fx.fpfh[i][b]));
      norm += std::abs(double(fx.fpfh[i][b]));
    }
    const double rel = norm > 0.0 ? diff / norm : diff;
    worst = std::max(worst, rel);
    sum_rel += rel;
    agree += rel <= 0.01 ? 1 : 0;
  }
  const double frac = double(agree) / double(fx.points.size());
  std::printf("fpfh: %zu points, within 1 %% L1: %.4f %%, mean rel L1 %.3g, worst %.3g, "
              "isolated %u\n",
              fx.points.size(), 100.0 * frac, sum_rel / double(fx.points.size()), worst,
              r.isolated);
  EXPECT_GE(frac, 0.99);
  EXPECT_EQ(r.search.truncated, 0u);
}

static KdNeighborhoods::Slot list_entries[kMax * 100];
static std::uint32_t list_begin[kMax];
static std::uint8_t list_count[kMax];

// The pipeline's path (one FPFH-radius search per point shared by normals and both FPFH passes)
// gives the same bits as the plain per-stage searches, with full and with overflowing storage.
TEST_F(FpfhOpen3d, SharedNeighborhoodsGiveIdenticalNormalsAndFeatures) {
  NormalParams np;
  np.radius = fx.normal_radius;
  np.max_nn = fx.normal_max_nn;
  np.viewpoint = fx.viewpoint;
  FpfhParams fp;
  fp.radius = fx.fpfh_radius;
  fp.max_nn = fx.fpfh_max_nn;
  const std::size_t n = fx.points.size();
  static Vec3f plain_normals[kMax], cached_normals[kMax];
  static Feature33 cached[kMax];
  estimate_normals(tree.tree, np, std::span<Vec3f>(plain_normals, n));
  compute_fpfh(tree.tree, fx.normals, fp, spfh, features);
  for (const std::size_t capacity : {kMax * 100, n * 10}) {
    KdNeighborhoods lists(tree.tree);
    lists.build(fp.radius, fp.max_nn, std::span<KdNeighborhoods::Slot>(list_entries, capacity),
                list_begin, list_count);
    if (capacity < kMax * 100) {
      EXPECT_GT(lists.not_cached(), 0u);
    }
    const NormalsResult nr = estimate_normals(lists, np, std::span<Vec3f>(cached_normals, n));
    ASSERT_EQ(nr.status, NormalsStatus::kOk);
    EXPECT_EQ(std::memcmp(plain_normals, cached_normals, sizeof(Vec3f) * n), 0);
    const FpfhResult fr = compute_fpfh(lists, fx.normals, fp, spfh, cached);
    ASSERT_EQ(fr.status, FpfhStatus::kOk);
    EXPECT_EQ(std::memcmp(features, cached, sizeof(Feature33) * n), 0);
  }
}

TEST_F(FpfhOpen3d, DeterministicAndPairFeatureConventions) {
  FpfhParams fp;
  fp.radius = fx.fpfh_radius;
  fp.max_nn = fx.fpfh_max_nn;
  compute_fpfh(tree.tree, fx.normals, fp, spfh, features);
  static Feature33 again[kMax];
  compute_fpfh(tree.tree, fx.normals, fp, spfh, again);
  EXPECT_EQ(std::memcmp(features, again, sizeof(Feature33) * fx.points.size()), 0);
  // Coincident points and parallel normal/line give the zero feature (Open3D).
  const PairFeature z = fpfh_pair_feature(Vec3d(1, 2, 3), Vec3d(0, 0, 1), Vec3d(1, 2, 3),
                                          Vec3d(0, 1, 0));
  EXPECT_EQ(z.f0, 0.0);
  EXPECT_EQ(z.distance, 0.0);
  const PairFeature par = fpfh_pair_feature(Vec3d(0, 0, 0), Vec3d(0, 0, 1), Vec3d(0, 0, 1),
                                            Vec3d(0, 0, 1));
  EXPECT_EQ(par.f1, 0.0);
  // Two points on a plane with equal normals: theta = 0, alpha = 0, phi = 0.
  const PairFeature flat = fpfh_pair_feature(Vec3d(0, 0, 0), Vec3d(0, 0, 1), Vec3d(1, 0, 0),
                                             Vec3d(0, 0, 1));
  EXPECT_NEAR(flat.f0, 0.0, 1e-15);
  EXPECT_NEAR(flat.f1, 0.0, 1e-15);
  EXPECT_NEAR(flat.f2, 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(flat.distance, 1.0);
  // A NaN normal is skipped and counted, never binned.
  std::vector<Vec3f> bad(fx.normals.begin(), fx.normals.end());
  bad[0] = Vec3f(NAN, NAN, NAN);
  const FpfhResult r = compute_fpfh(tree.tree, bad, fp, spfh, features);
  EXPECT_GT(r.non_finite_pairs, 0u);
  for (int b = 0; b < kFpfhBins; ++b) ASSERT_TRUE(std::isfinite(features[1][b]));
}

}  // namespace
}  // namespace v2xloc
