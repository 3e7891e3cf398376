#include "v2xloc/algo/localization/basin_audit.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "corner_map.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc {
namespace {

// Configured as the Localizer configures it.
void configure(BasinAudit& audit, const LocalizerParams& params) {
  audit.configure(params.audit, params.startup.search, params.tracking.icp);
}

struct AuditMarks {
  int audit = 0;
  static void mark(void* context, LocalizerStage stage) {
    if (stage == LocalizerStage::kAudit) ++static_cast<AuditMarks*>(context)->audit;
  }
};

// Three orthogonal walls as the map, the first 600 of their points as the scan.
struct AuditScene {
  testing::CornerMap map;
  std::vector<Vec3f> scan;
  std::vector<std::uint32_t> hints;
  AuditMarks marks;
  std::unique_ptr<PoseSearchScratch> scratch = std::make_unique<PoseSearchScratch>();

  AuditScene() {
    scan.assign(map.points.begin(), map.points.begin() + 600);
    hints.resize(scan.size());
  }
  AuditFrame frame() {
    AuditFrame f;
    f.scan = scan;
    f.search_scan = scan;
    f.map = map.target();
    f.icp_hints = hints;
    f.probe = StageProbe{&AuditMarks::mark, &marks};
    return f;
  }
};

// An audit is insurance: in a period that fused map clouds (map_busy) it takes the smaller busy
// quota, or with none neither starts nor advances and resumes in the next quiet period.
TEST(BasinAudit, WaitsOutPeriodsThatFusedMapClouds) {
  AuditScene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  AuditMarks& marks = scene.marks;
  LocalizerParams params;
  params.audit.period_frames = 1;
  params.audit.work_per_period = 1000;  // a job over many periods
  params.audit.work_per_busy_period = 0;
  auto audit = std::make_unique<BasinAudit>();
  configure(*audit, params);
  LocalizerCounters counters;
  AuditFrame f = scene.frame();
  // A new track's first audit takes the period's whole room (here unbounded: it ends at once),
  // busy or not; the quotas below are those of the audits after it.
  const auto first_audit_of_track = [&](std::uint32_t frame) {
    f.map_busy = true;
    f.frame = frame;
    EXPECT_TRUE(audit->step(f, *scene.scratch, counters).audited) << "the first audit of a track";
    marks.audit = 0;
  };
  first_audit_of_track(0);

  f.map_busy = true;
  for (std::uint32_t k = 0; k < 3; ++k) {
    f.frame = k;
    EXPECT_FALSE(audit->step(f, *scene.scratch, counters).audited);
  }
  EXPECT_EQ(marks.audit, 0) << "due, but no audit starts in a busy period";
  f.map_busy = false;
  f.frame = 3;
  audit->step(f, *scene.scratch, counters);
  EXPECT_EQ(marks.audit, 1) << "started in the first quiet period";
  f.map_busy = true;
  f.frame = 4;
  EXPECT_FALSE(audit->step(f, *scene.scratch, counters).audited);
  EXPECT_EQ(marks.audit, 1) << "paused";
  f.map_busy = false;
  f.frame = 5;
  audit->step(f, *scene.scratch, counters);
  EXPECT_EQ(marks.audit, 2) << "resumed";

  params.audit.work_per_busy_period = 500;  // busy periods advance it, by less
  configure(*audit, params);
  first_audit_of_track(6);
  f.map_busy = true;
  f.frame = 7;
  EXPECT_FALSE(audit->step(f, *scene.scratch, counters).audited);
  EXPECT_EQ(marks.audit, 1) << "a busy quota: started in a busy period";
}


// A new track (power-up, or after a lost one) is audited after audit.first_frames tracked frames
// (a start-up search on a map missing a unit's shares can accept an alias); later audits come
// every audit.period_frames.
TEST(BasinAudit, NewTrackIsAuditedEarly) {
  AuditScene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  params.audit.period_frames = 30;
  params.audit.first_frames = 5;
  params.audit.work_per_period = 0;  // each audit in one period
  auto audit = std::make_unique<BasinAudit>();
  configure(*audit, params);
  LocalizerCounters counters;
  AuditFrame f = scene.frame();
  std::vector<std::uint32_t> audited;
  for (std::uint32_t k = 0; k < 70; ++k) {
    f.frame = k;
    if (audit->step(f, *scene.scratch, counters).audited) audited.push_back(k);
  }
  ASSERT_GE(audited.size(), 2u);
  EXPECT_EQ(audited[0], 4u) << "the fifth tracked frame";
  EXPECT_EQ(audited[1], 34u) << "then every 30";
  audit->cancel();  // track lost: the next track is new
  f.frame = 100;
  for (std::uint32_t k = 0; k < 5; ++k, ++f.frame) {
    EXPECT_EQ(audit->step(f, *scene.scratch, counters).audited, k == 4) << "tracked frame " << k << " of the new track";
  }
  params.audit.first_frames = 30;  // no early audit: the first after a whole period
  configure(*audit, params);
  std::uint32_t first = 0;
  for (std::uint32_t k = 0; k < 40 && first == 0; ++k) {
    f.frame = 200 + k;
    if (audit->step(f, *scene.scratch, counters).audited) first = k + 1;
  }
  EXPECT_EQ(first, 30u);
}

// Tracking 3 m off the walls (another basin): the audit nominates the true one. Its full-scan
// decision is priced: a frame without room for it leaves the nomination pending (no switch yet),
// and the next frame decides it within its room (the evaluations on a subsample).
TEST(BasinAudit, ANominationIsDecidedWithinThePeriodsRoom) {
  AuditScene scene;
  ASSERT_TRUE(scene.map.normals_ok);
  LocalizerParams params;
  params.audit.period_frames = 1;
  params.audit.first_frames = 1;
  params.audit.work_per_period = 0;  // the search in one period
  params.audit.decision.min_points = 100;
  auto audit = std::make_unique<BasinAudit>();
  configure(*audit, params);
  LocalizerCounters counters;
  AuditFrame f = scene.frame();
  f.tracked = Pose3d::Identity();
  f.tracked.translation() = Vec3d(3.0, 3.0, 0.0);
  f.tracking_scan = scene.scan;
  f.sensor_in_body = Vec3d(1.0, 1.0, 1.8);  // rays from inside the corner: none crosses a wall
  f.decision.pass_price = 1000.0;
  f.decision.evaluation_price = 1000.0;
  const double n = static_cast<double>(scene.scan.size());
  f.decision.room = 0.5 * n * f.decision.pass_price;  // not one pass
  const AuditOutcome first = audit->step(f, *scene.scratch, counters);
  ASSERT_TRUE(first.audited);
  EXPECT_FALSE(first.switch_basin) << "nominated, but the room holds no decision";
  EXPECT_EQ(first.queries, 0u);
  AuditOutcome out;
  std::uint32_t frames = 0;
  for (std::uint32_t k = 1; k <= params.audit.decision.max_deferred_frames + 2 && !out.switch_basin; ++k) {
    f.frame = k;
    f.decision.room = 2.5 * n * f.decision.pass_price;  // two passes a frame
    out = audit->step(f, *scene.scratch, counters);
    ++frames;
    EXPECT_FALSE(out.audited) << "no new audit while a nomination is pending";
    const double priced = static_cast<double>(out.queries) * f.decision.pass_price +
                          static_cast<double>(out.evaluated) * f.decision.evaluation_price;
    if (k <= params.audit.decision.max_deferred_frames) {
      EXPECT_LE(priced, f.decision.room) << "frame " << k;
    }
  }
  ASSERT_TRUE(out.switch_basin) << "decided within " << frames << " frames";
  EXPECT_LT(out.candidate.translation().norm(), 0.05) << "the walls' true pose";
  EXPECT_EQ(counters.basin_switches, 1u);
}

}  // namespace
}  // namespace v2xloc
