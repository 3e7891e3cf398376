#include "v2xloc/algo/localization/basin_audit.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/search/kdtree.hpp"

namespace v2xloc {
namespace {

struct AuditMarks {
  int audit = 0;
  static void mark(void* context, LocalizerStage stage) {
    if (stage == LocalizerStage::kAudit) ++static_cast<AuditMarks*>(context)->audit;
  }
};

// An audit is insurance: in a period that fused map clouds (map_busy) it takes the smaller busy
// quota, or with none neither starts nor advances and resumes in the next quiet period.
TEST(BasinAudit, WaitsOutPeriodsThatFusedMapClouds) {
  std::vector<Vec3f> map_points;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 15; ++j) {
      map_points.emplace_back(0.5f * i, 0.0f, 0.5f * j);
      map_points.emplace_back(0.0f, 0.5f * i, 0.5f * j);
      map_points.emplace_back(0.5f * i, 0.5f * j, 0.0f);
    }
  auto tree = std::make_unique<KdTreeStorage<Vec3f, 4096>>();
  tree->build(map_points);
  std::vector<Vec3f> normals(map_points.size());
  NormalParams np;
  np.radius = 1.2f;
  ASSERT_EQ(estimate_normals(tree->tree, np, normals).status, NormalsStatus::kOk);
  const IcpTarget map{map_points, normals, &tree->tree, nullptr, nullptr};
  std::vector<Vec3f> scan(map_points.begin(), map_points.begin() + 600);
  std::vector<std::uint32_t> hints(scan.size());

  LocalizerParams params;
  params.audit_period_frames = 1;
  params.audit_work_per_period = 1000;  // a job over many periods
  params.audit_work_per_busy_period = 0;
  auto audit = std::make_unique<BasinAudit>();
  audit->configure(params);
  AuditMarks marks;
  LocalizerCounters counters;
  AuditFrame f;
  f.scan = scan;
  f.search_scan = scan;
  f.map = map;
  f.icp_hints = hints;
  f.probe = StageProbe{&AuditMarks::mark, &marks};

  f.map_busy = true;
  for (std::uint32_t k = 0; k < 3; ++k) {
    f.frame = k;
    EXPECT_FALSE(audit->step(f, counters).audited);
  }
  EXPECT_EQ(marks.audit, 0) << "due, but no audit starts in a busy period";
  f.map_busy = false;
  f.frame = 3;
  audit->step(f, counters);
  EXPECT_EQ(marks.audit, 1) << "started in the first quiet period";
  f.map_busy = true;
  f.frame = 4;
  EXPECT_FALSE(audit->step(f, counters).audited);
  EXPECT_EQ(marks.audit, 1) << "paused";
  f.map_busy = false;
  f.frame = 5;
  audit->step(f, counters);
  EXPECT_EQ(marks.audit, 2) << "resumed";

  params.audit_work_per_busy_period = 500;  // busy periods advance it, by less
  audit->configure(params);
  f.map_busy = true;
  f.frame = 6;
  audit->step(f, counters);
  EXPECT_EQ(marks.audit, 3) << "a busy quota: started in a busy period";
}

}  // namespace
}  // namespace v2xloc
