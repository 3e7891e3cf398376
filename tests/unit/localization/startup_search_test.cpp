#include "v2xloc/algo/localization/startup_search.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "corner_map.hpp"

namespace v2xloc {
namespace {

// The corner map; the scan is a part of it (body = world).
struct CornerScene {
  testing::CornerMap map;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;

  CornerScene() {
    scan.assign(map.points.begin(), map.points.begin() + 900);
    hints.resize(scan.size());
  }
  StartupFrame frame(std::uint32_t index, const Vec3d& fix) {
    StartupFrame f;
    f.frame = index;
    f.t = 0.1 * index;
    f.scan = scan;
    f.search_scan = scan;
    f.tracking_scan = scan;
    f.map = map.target();
    f.gnss.valid = true;
    f.gnss.enu = fix;
    f.gnss.sigma = 3.0;
    f.filter_needs_start = true;
    f.icp_hints = hints;
    return f;
  }
};

// A canyon fix can be further off than the region's floor: a search that leaves nothing standing
// makes the next one look wider (up to global_max_region), and a new track starts at the floor.
TEST(StartupSearch, RegionWidensAfterASearchFindsNothing) {
  CornerScene scene;
  LocalizerParams params;
  auto search = std::make_unique<StartupSearch>();
  search->configure(params);
  LocalizerCounters counters;
  const Vec3d fix(300.0, 300.0, 0.0);  // no map anywhere near it: nothing can be found
  std::vector<double> regions;
  for (std::uint32_t frame = 0; frame < 40 && regions.size() < 3; ++frame) {
    search->on_frame(true, Pose3d::Identity(), GnssFix{});
    const StartupOutcome out = search->step(scene.frame(frame, fix), counters);
    if (!out.report.searched) continue;
    EXPECT_EQ(out.status, StartupStatus::kRejected);
    regions.push_back(out.report.region);
  }
  ASSERT_EQ(regions.size(), 3u);
  EXPECT_DOUBLE_EQ(regions[0], params.global_min_region);
  EXPECT_DOUBLE_EQ(regions[1], params.global_min_region * params.global_region_growth);
  EXPECT_DOUBLE_EQ(regions[2], params.global_max_region) << "capped";
  EXPECT_EQ(counters.global_accepted, 0u);

  search->on_track_lost();  // a new track: back to the floor
  for (std::uint32_t frame = 40; frame < 80; ++frame) {
    search->on_frame(true, Pose3d::Identity(), GnssFix{});
    const StartupOutcome out = search->step(scene.frame(frame, fix), counters);
    if (!out.report.searched) continue;
    EXPECT_DOUBLE_EQ(out.report.region, params.global_min_region);
    break;
  }
}

// The localizer takes no map clouds while the first acquisition is pending (its searches ignore
// the period budget): that window ends at startup_first_frames, or with the filter's start.
TEST(StartupSearch, FirstAcquisitionWindow) {
  LocalizerParams params;
  auto search = std::make_unique<StartupSearch>();
  search->configure(params);
  EXPECT_TRUE(search->first_acquisition_pending(0));
  EXPECT_TRUE(search->first_acquisition_pending(params.startup_first_frames - 1));
  EXPECT_FALSE(search->first_acquisition_pending(params.startup_first_frames));
  params.startup_first_work_per_period = 0;  // no exception slice: nothing to make room for
  search->configure(params);
  EXPECT_FALSE(search->first_acquisition_pending(0));
}

}  // namespace
}  // namespace v2xloc
