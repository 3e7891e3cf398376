// Surveyed backgrounds (surveyed_background.hpp) and map fusion's check of an infrastructure
// cloud against its unit's background: a genuine sweep of the unit's scene is accepted, the same
// sweep with its points moved 0.25 m, 3 m or 200 m under the true pose is rejected and counted,
// a unit without a background is handled exactly as before, and a background that is not sorted,
// not bounded or has an unusable cell is refused when it is handed over.
#include "v2xloc/algo/localization/surveyed_background.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/map_fusion.hpp"

namespace v2xloc {
namespace {

// A roadside unit 5 m up at (2, -3), yawed 0.7 rad, over a street corner: ground, two facades,
// a pillar. Its sweeps are cast ray by ray (32 beams from +10 to -30 deg, 512 columns), 2 cm
// range noise from `seed`, so every sweep fires the same rays as a real unit does.
struct Unit {
  Mat4d world_T_sensor = Mat4d::Identity();
  Unit() {
    world_T_sensor.topLeftCorner<3, 3>() = rot_z(0.7);
    world_T_sensor.topRightCorner<3, 1>() = Vec3d(2.0, -3.0, 5.0);
  }
  Mat3d sensor_R_world() const { return world_T_sensor.topLeftCorner<3, 3>().transpose(); }

  // Nearest hit along o + t d (world frame) within 100 m, else -1.
  static double cast(const Vec3d& o, const Vec3d& d) {
    double best = -1.0;
    const auto take = [&](double t, const Vec3d& /*hit*/, bool inside) {
      if (t > 0.5 && t < 100.0 && inside && (best < 0.0 || t < best)) best = t;
    };
    if (d.z() < 0.0) {  // ground z = 0
      const double t = -o.z() / d.z();
      const Vec3d p = o + t * d;
      take(t, p, std::abs(p.x()) < 60.0 && std::abs(p.y()) < 60.0);
    }
    if (d.x() > 0.0) {  // facade x = 18, 9 m high
      const double t = (18.0 - o.x()) / d.x();
      const Vec3d p = o + t * d;
      take(t, p, p.z() >= 0.0 && p.z() <= 9.0 && std::abs(p.y()) < 40.0);
    }
    if (d.y() < 0.0) {  // facade y = -15, 7 m high
      const double t = (-15.0 - o.y()) / d.y();
      const Vec3d p = o + t * d;
      take(t, p, p.z() >= 0.0 && p.z() <= 7.0 && std::abs(p.x()) < 40.0);
    }
    for (int axis = 0; axis < 2; ++axis) {  // pillar: faces of the box [7, 8] x [3, 4] x [0, 4]
      for (const double face : {axis == 0 ? 7.0 : 3.0, axis == 0 ? 8.0 : 4.0}) {
        if (d(axis) == 0.0) continue;
        const double t = (face - o(axis)) / d(axis);
        const Vec3d p = o + t * d;
        const int other = 1 - axis;
        const double lo = axis == 0 ? 3.0 : 7.0;
        take(t, p, p.z() >= 0.0 && p.z() <= 4.0 && p(other) >= lo && p(other) <= lo + 1.0);
      }
    }
    return best;
  }

  std::vector<Vec3f> sweep(unsigned seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.02);
    const Mat3d R = world_T_sensor.topLeftCorner<3, 3>();
    const Vec3d o = world_T_sensor.topRightCorner<3, 1>();
    std::vector<Vec3f> points;
    for (int c = 0; c < 512; ++c) {
      const double az = -M_PI + 2.0 * M_PI * (c + 0.5) / 512;
      for (int b = 0; b < 32; ++b) {
        const double el = (10.0 - 40.0 * b / 31.0) * M_PI / 180.0;
        const Vec3d ds(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
        const double n = noise(rng);  // drawn for every ray: the stream does not depend on hits
        const double t = cast(o, R * ds);
        if (t > 0.0) points.push_back(((t + n) * ds).cast<float>());
      }
    }
    return points;
  }

  // Points moved by `world_shift` (metres, world axes) under the unchanged pose.
  std::vector<Vec3f> moved(const std::vector<Vec3f>& points, const Vec3d& world_shift) const {
    const Vec3f o = (sensor_R_world() * world_shift).cast<float>();
    std::vector<Vec3f> out = points;
    for (Vec3f& p : out) p += o;
    return out;
  }
};

// The survey: three sweeps merged into cells; the cell grows x 9/8 from 0.1 m until they fit
// config::kBackgroundFileCells (as the simulator writes them).
struct Survey {
  double cell = 0.1;
  std::vector<std::uint32_t> cells;
  explicit Survey(const Unit& unit) {
    std::vector<Vec3f> points;
    for (unsigned s = 100; s < 103; ++s) {
      const std::vector<Vec3f> sweep = unit.sweep(s);
      points.insert(points.end(), sweep.begin(), sweep.end());
    }
    for (;; cell *= 1.125) {
      cells.clear();
      for (const Vec3f& p : points) {
        std::uint32_t key = 0;
        if (background_cell_key(p, 1.0 / cell, key)) cells.push_back(key);
      }
      std::sort(cells.begin(), cells.end());
      cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
      if (cells.size() <= config::kBackgroundFileCells) break;
    }
  }
  SurveyedBackground background() const { return {cell, cells}; }
};

class SurveyedBackgroundTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    unit_ = new Unit();
    survey_ = new Survey(*unit_);
    genuine_ = new std::vector<Vec3f>(unit_->sweep(7));
  }
  static void TearDownTestSuite() {
    delete genuine_;
    delete survey_;
    delete unit_;
  }
  static MapFusion& fresh_map() {
    static MapFusion map;  // ~9 MB
    map.configure(MapFusionParams{});
    return map;
  }
  static Unit* unit_;
  static Survey* survey_;
  static std::vector<Vec3f>* genuine_;
};
Unit* SurveyedBackgroundTest::unit_ = nullptr;
Survey* SurveyedBackgroundTest::survey_ = nullptr;
std::vector<Vec3f>* SurveyedBackgroundTest::genuine_ = nullptr;

TEST_F(SurveyedBackgroundTest, GenuineSweepPeaksOnItsBackground) {
  ASSERT_TRUE(background_valid(survey_->background()));
  const BackgroundScore s = check_background(survey_->background(), *genuine_, unit_->sensor_R_world(), {});
  EXPECT_TRUE(s.consistent);
  EXPECT_LE(s.sampled, config::kBackgroundCheckPoints);  // an even stride: at most the cap, at least half
  EXPECT_GT(s.sampled, config::kBackgroundCheckPoints / 2);
  EXPECT_GT(s.fitness, 0.9);
  EXPECT_LT(s.best_probe, s.fitness);
}

TEST_F(SurveyedBackgroundTest, PointsMovedUnderTheTruePoseAreRejected) {
  const BackgroundCheckParams params;
  for (const double d : {0.25, 3.0, 200.0}) {
    for (const Vec3d& dir : {Vec3d(1, 0, 0), Vec3d(0, -1, 0), Vec3d(0, 0, 1)}) {
      const BackgroundScore s = check_background(survey_->background(), unit_->moved(*genuine_, d * dir),
                                                 unit_->sensor_R_world(), params);
      EXPECT_FALSE(s.consistent) << d << " m along " << dir.transpose();
      // Either off the scene (below the floor) or better displaced back (the peak test).
      EXPECT_TRUE(s.fitness < params.min_fitness || s.best_probe > s.fitness + params.probe_margin)
          << d << " m: fitness " << s.fitness << " best probe " << s.best_probe;
    }
  }
}

TEST_F(SurveyedBackgroundTest, TooFewPointsShowNothingOfTheScene) {
  const std::vector<Vec3f> few(genuine_->begin(), genuine_->begin() + 10);
  EXPECT_FALSE(check_background(survey_->background(), few, unit_->sensor_R_world(), {}).consistent);
  std::vector<Vec3f> nan(200, Vec3f::Constant(std::nanf("")));
  const BackgroundScore s = check_background(survey_->background(), nan, unit_->sensor_R_world(), {});
  EXPECT_FALSE(s.consistent);
  EXPECT_EQ(s.sampled, 0u);
}

TEST_F(SurveyedBackgroundTest, CellKeysStayInTheirSpan) {
  std::uint32_t key = 0;
  EXPECT_TRUE(background_cell_key(Vec3f(102.0f, -102.0f, -51.0f), 10.0, key));
  EXPECT_FALSE(background_cell_key(Vec3f(102.5f, 0.0f, 0.0f), 10.0, key));  // x beyond 1024 cells
  EXPECT_FALSE(background_cell_key(Vec3f(0.0f, 0.0f, 51.3f), 10.0, key));   // z beyond 512 cells
  EXPECT_FALSE(background_cell_key(Vec3f(std::nanf(""), 0.0f, 0.0f), 10.0, key));
  EXPECT_FALSE(background_cell_key(Vec3f(0.0f, std::numeric_limits<float>::infinity(), 0.0f), 10.0, key));
  std::uint32_t a = 0, b = 0;  // keys order cells by x first
  ASSERT_TRUE(background_cell_key(Vec3f(-0.05f, 50.0f, 50.0f), 10.0, a));
  ASSERT_TRUE(background_cell_key(Vec3f(0.05f, -50.0f, -50.0f), 10.0, b));
  EXPECT_LT(a, b);
}

// The check's zero-offset fitness is plain set membership of each sampled point's cell, whatever
// the keys' spread: cells at both ends of the key span, clusters and lone cells, points on them,
// beside them and outside the span, counted against std::binary_search over the same keys.
TEST_F(SurveyedBackgroundTest, FitnessIsCellMembershipOverTheWholeKeySpan) {
  const double cell_size = 0.1;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> xy(-102.3f, 102.3f), z(-51.1f, 51.1f);
  std::vector<Vec3f> seeds = {Vec3f(-102.35f, -102.35f, -51.15f), Vec3f(102.35f, 102.35f, 51.15f)};
  for (int i = 0; i < 150; ++i) seeds.emplace_back(xy(rng), xy(rng), z(rng));
  for (int i = 0; i < 150; ++i) seeds.emplace_back(3.0f + 0.02f * i, -2.0f, 0.5f);  // a dense run
  std::vector<std::uint32_t> keys;
  for (const Vec3f& p : seeds) {
    std::uint32_t k = 0;
    if (background_cell_key(p, 1.0 / cell_size, k)) keys.push_back(k);
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  const SurveyedBackground bg{cell_size, keys};
  ASSERT_TRUE(background_valid(bg));

  std::vector<Vec3f> points;
  for (const Vec3f& p : seeds) {
    points.push_back(p);                              // on a cell
    points.push_back(p + Vec3f(0.1f, 0.0f, 0.0f));    // the next cell along x
    points.push_back(p + Vec3f(0.0f, 0.0f, -0.1f));   // the next cell down
  }
  points.emplace_back(200.0f, 0.0f, 0.0f);  // outside the key span
  std::uint32_t hits = 0, finite = 0;
  for (const Vec3f& p : points) {
    std::uint32_t k = 0;
    ++finite;
    if (background_cell_key(p, 1.0 / cell_size, k) && std::binary_search(keys.begin(), keys.end(), k)) ++hits;
  }
  BackgroundCheckParams params;
  params.max_points = config::kBackgroundCheckPoints;
  params.min_fitness = 2.0;  // score only: no probes
  ASSERT_LE(points.size(), config::kBackgroundCheckPoints);  // every point sampled
  const BackgroundScore s = check_background(bg, points, Mat3d::Identity(), params);
  EXPECT_EQ(s.sampled, finite);
  EXPECT_EQ(s.fitness, static_cast<double>(hits) / finite);
  EXPECT_GT(hits, seeds.size() / 2);
  EXPECT_LT(hits, points.size() - 1);
}

TEST_F(SurveyedBackgroundTest, UnusableBackgroundsAreRefused) {
  MapFusion& map = fresh_map();
  const std::vector<std::uint32_t>& good = survey_->cells;
  std::vector<std::uint32_t> unsorted = good;
  std::swap(unsorted[10], unsorted[11]);
  std::vector<std::uint32_t> duplicate = good;
  duplicate[11] = duplicate[10];
  const std::vector<std::uint32_t> too_many(config::kMaxBackgroundCells + 1, 0u);
  EXPECT_FALSE(map.set_background(1, {survey_->cell, unsorted}));
  EXPECT_FALSE(map.set_background(1, {survey_->cell, duplicate}));
  EXPECT_FALSE(map.set_background(1, {survey_->cell, {}}));
  EXPECT_FALSE(map.set_background(1, {survey_->cell, too_many}));
  EXPECT_FALSE(map.set_background(1, {0.0, good}));
  EXPECT_FALSE(map.set_background(1, {std::nan(""), good}));
  EXPECT_FALSE(map.set_background(1, {kBackgroundMaxCell * 2.0, good}));
  EXPECT_EQ(map.background(1), nullptr);
  // One slot per unit; a second call replaces the unit's; the table is bounded.
  for (std::uint32_t id = 1; id <= config::kMaxBackgroundUnits; ++id) EXPECT_TRUE(map.set_background(id, survey_->background()));
  EXPECT_TRUE(map.set_background(1, survey_->background()));
  EXPECT_FALSE(map.set_background(static_cast<std::uint32_t>(config::kMaxBackgroundUnits) + 1, survey_->background()));
  ASSERT_NE(map.background(1), nullptr);
  EXPECT_EQ(map.background(1)->cells.data(), survey_->cells.data());  // the caller's storage, not a copy
  map.configure(MapFusionParams{});
  EXPECT_EQ(map.background(1), nullptr);  // configure() resets the provisioning
}

TEST_F(SurveyedBackgroundTest, MapFusionAcceptsTheGenuineUnit) {
  MapFusion& map = fresh_map();
  ASSERT_TRUE(map.set_background(5, survey_->background()));
  const MapInsertResult r = map.insert(5, 1.0, Pose3d(unit_->world_T_sensor), *genuine_, true);
  EXPECT_EQ(r.status, MapInsertStatus::kInserted);
  EXPECT_TRUE(r.background_checked);
  EXPECT_TRUE(r.background.consistent);
  EXPECT_GT(map.point_count(), 1000u);
  EXPECT_EQ(map.counters().background_checked, 1u);
  EXPECT_EQ(map.counters().background_mismatch, 0u);
}

TEST_F(SurveyedBackgroundTest, MapFusionRejectsAndCountsMovedPoints) {
  MapFusion& map = fresh_map();
  ASSERT_TRUE(map.set_background(5, survey_->background()));
  double t = 1.0;
  for (const double d : {0.25, 3.0, 200.0}) {
    const MapInsertResult r = map.insert(5, t, Pose3d(unit_->world_T_sensor), unit_->moved(*genuine_, Vec3d(d, 0, 0)), true);
    t += 1.0;
    EXPECT_EQ(r.status, MapInsertStatus::kBackgroundMismatch) << d << " m";
    EXPECT_TRUE(r.background_checked);
    EXPECT_EQ(map.point_count(), 0u) << d << " m";
  }
  EXPECT_EQ(map.counters().background_checked, 3u);
  EXPECT_EQ(map.counters().background_mismatch, 3u);
  EXPECT_EQ(map.counters().rejected_inconsistent, 0u);  // its own counter, not the quorum's
  // The unit's genuine cloud afterwards is fused.
  EXPECT_EQ(map.insert(5, t, Pose3d(unit_->world_T_sensor), *genuine_, true).status, MapInsertStatus::kInserted);
}

// The verdict a caller can ask for before paying a share's signature check: insert()'s background
// verdict, with nothing inserted or counted.
TEST_F(SurveyedBackgroundTest, FitsBackgroundIsInsertsVerdictWithoutSideEffects) {
  MapFusion& map = fresh_map();
  ASSERT_TRUE(map.set_background(5, survey_->background()));
  const Pose3d pose(unit_->world_T_sensor);
  EXPECT_TRUE(map.fits_background(5, pose.matrix(), *genuine_));
  for (const double d : {0.25, 3.0, 200.0}) {
    EXPECT_FALSE(map.fits_background(5, pose.matrix(), unit_->moved(*genuine_, Vec3d(d, 0, 0)))) << d << " m";
  }
  EXPECT_TRUE(map.fits_background(6, pose.matrix(), unit_->moved(*genuine_, Vec3d(3.0, 0, 0))))
      << "a unit without a background is not judged here";
  EXPECT_EQ(map.counters().background_checked, 0u);
  EXPECT_EQ(map.point_count(), 0u);
  MapFusionParams off;
  off.check_background = false;
  map.configure(off);
  ASSERT_TRUE(map.set_background(5, survey_->background()));
  EXPECT_TRUE(map.fits_background(5, pose.matrix(), unit_->moved(*genuine_, Vec3d(3.0, 0, 0))));
}

// A cloud the caller already found on its background (fits_background, before its signature
// check) is not scored again: the same verdict and counts as scoring it, the score itself not taken.
TEST_F(SurveyedBackgroundTest, ACloudTheCallerFoundOnItsBackgroundIsNotScoredAgain) {
  const Pose3d pose(unit_->world_T_sensor);
  MapFusion& scored = fresh_map();
  ASSERT_TRUE(scored.set_background(5, survey_->background()));
  ASSERT_TRUE(scored.fits_background(5, pose.matrix(), *genuine_));
  const MapInsertResult a = scored.insert(5, 1.0, pose, *genuine_, true);
  const std::uint32_t points = scored.point_count();
  static MapFusion vouched;
  vouched.configure(MapFusionParams{});
  ASSERT_TRUE(vouched.set_background(5, survey_->background()));
  const MapInsertResult b = vouched.insert(5, 1.0, pose, *genuine_, true, true);
  EXPECT_EQ(b.status, a.status);
  EXPECT_TRUE(b.background_checked);
  EXPECT_TRUE(b.background.consistent);
  EXPECT_GT(a.background.sampled, 0u);
  EXPECT_EQ(b.background.sampled, 0u) << "not scored";
  EXPECT_EQ(vouched.point_count(), points);
  EXPECT_EQ(vouched.counters().background_checked, scored.counters().background_checked);
}

TEST_F(SurveyedBackgroundTest, UnitsWithoutABackgroundAreHandledAsBefore) {
  const std::vector<Vec3f> moved = unit_->moved(*genuine_, Vec3d(3.0, 0, 0));
  // The same inserts into a map with no backgrounds and into one where only another unit has one.
  static MapFusion plain;
  plain.configure(MapFusionParams{});
  MapFusion& provisioned = fresh_map();
  ASSERT_TRUE(provisioned.set_background(9, survey_->background()));
  for (MapFusion* map : {&plain, &provisioned}) {
    EXPECT_EQ(map->insert(5, 1.0, Pose3d(unit_->world_T_sensor), moved, true).status, MapInsertStatus::kInserted);
    // An agent under the background's id is not checked against it: backgrounds are infrastructure's.
    EXPECT_NE(map->insert(9, 1.5, Pose3d(unit_->world_T_sensor), moved, false).status, MapInsertStatus::kBackgroundMismatch);
    EXPECT_EQ(map->counters().background_checked, 0u);
  }
  EXPECT_EQ(plain.point_count(), provisioned.point_count());
  EXPECT_EQ(plain.counters().inserted, provisioned.counters().inserted);
  EXPECT_EQ(plain.counters().held_back, provisioned.counters().held_back);
  EXPECT_EQ(plain.counters().rejected_inconsistent, provisioned.counters().rejected_inconsistent);
}

TEST_F(SurveyedBackgroundTest, CheckCanBeSwitchedOff) {
  MapFusionParams params;
  params.check_background = false;
  MapFusion& map = fresh_map();
  map.configure(params);
  ASSERT_TRUE(map.set_background(5, survey_->background()));
  const MapInsertResult r = map.insert(5, 1.0, Pose3d(unit_->world_T_sensor), unit_->moved(*genuine_, Vec3d(3.0, 0, 0)), true);
  EXPECT_EQ(r.status, MapInsertStatus::kInserted);
  EXPECT_FALSE(r.background_checked);
}

}  // namespace
}  // namespace v2xloc
