// A 5 s drive of Sim 0 (2_infra: the sparsest map) at full sensor resolution, through the
// localizer exactly as v2xloc-eval runs it. Thresholds and why:
//  - the filter must initialize within 20 frames: the GNSS-seeded search runs every 2 frames
//    and the scene is 40 m from the intersection, inside the infrastructure coverage;
//  - mean fused error over gate-valid frames <= 0.05 m: the evaluation target is 0.015 m on
//    20 s recordings; a 5 s clip has fewer valid frames and a start far from the sensors, so
//    we leave a 3x margin while still failing on any real regression (a broken deskew,
//    gate or fusion measures decimetres to metres);
//  - every frame after initialization within 0.25 m (no divergence).
//  - zero heap allocations inside the localizer's calls after configure().
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "firmware/app/alloc_counter.hpp"
#include "host_sim/recording/recorder.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "tools/eval/metrics.hpp"
#include "tools/eval/offline_run.hpp"
#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc {
namespace {

Localizer g_localizer;

TEST(LocalizerScenario, ShortDriveFusesToCentimetres) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("v2xloc_localizer_scenario_sim0_2infra_" + std::to_string(::getpid()));  // parallel runs
  std::filesystem::remove_all(dir);
  sim::RecorderConfig cfg;
  cfg.scenario = 0;
  cfg.permutation = sim::Permutation::k2Infra;
  cfg.duration = 5.0;
  cfg.stereo = false;
  cfg.out_dir = dir.string();
  sim::RecordingSummary summary;
  std::string error;
  ASSERT_TRUE(sim::generate_recording(cfg, summary, error, nullptr)) << error;

  sim::RecordingReader reader;
  ASSERT_TRUE(reader.open(dir.string(), error)) << error;
  eval::RunOptions options;
  options.quiet = true;
  std::vector<eval::FrameRecord> records;
  eval::RunStats stats;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, options, records, stats, error)) << error;
  ASSERT_EQ(records.size(), 50u);

  int first = -1;
  for (std::size_t i = 0; i < records.size(); ++i) {
    if (records[i].out.filter_initialized) {
      first = static_cast<int>(i);
      break;
    }
  }
  ASSERT_GE(first, 0) << "filter never initialized";
  EXPECT_LE(first, 20);
  double worst = 0.0;
  for (std::size_t i = static_cast<std::size_t>(first); i < records.size(); ++i) {
    const Eigen::Vector3d e = records[i].out.fused_pose.translation() - records[i].truth.translation();
    worst = std::max(worst, e.norm());
  }
  EXPECT_LT(worst, 0.25);
  // The filter's start revised every start-up frame (the odometry never failed on this drive):
  // carried back by the odometry they are as good as the tracked frames. 0.25 m as above: the
  // start pose's few-cm error plus the odometry's drift over <= 2 s (a few cm).
  double worst_revised = 0.0;
  for (int i = 0; i < first; ++i) {
    EXPECT_TRUE(records[static_cast<std::size_t>(i)].revised) << "frame " << i;
    const Eigen::Vector3d e = records[static_cast<std::size_t>(i)].lagged_pose.topRightCorner<3, 1>() -
                              records[static_cast<std::size_t>(i)].truth.translation();
    worst_revised = std::max(worst_revised, e.norm());
  }
  EXPECT_LT(worst_revised, 0.25);
  const eval::RowMetrics m = eval::compute_metrics(records);
  EXPECT_EQ(m.revised_frames, first);
  EXPECT_LT(m.unaligned.fused_lag, 0.05);
  // Every frame, start-up included (the paper's "Fused"): the start-up search puts the output on
  // the map from the first frame (12 recordings: output from frame 0, filter from frame 2). One
  // frame left at the GNSS fix (~10 m off) adds 0.2 m to a 50-frame mean, so 5 cm (5x the
  // tracked error) fails exactly when the start-up falls back to the GNSS.
  EXPECT_LT(m.unaligned.fused, 0.05);
  EXPECT_GT(m.valid_frames, 10);
  EXPECT_GE(m.unaligned.fused_valid, 0.0);
  EXPECT_LT(m.unaligned.fused_valid, 0.05);
  EXPECT_LT(m.unaligned.reg_valid, 0.05);
  std::printf("init frame %d, valid %d, fused(valid) %.4f m, reg(valid) %.4f m, worst %.3f m, "
              "GNSS %.2f m, fused %.3f m, fused (lag) %.4f m, worst revised %.3f m\n", first,
              m.valid_frames, m.unaligned.fused_valid, m.unaligned.reg_valid, worst, m.unaligned.gps,
              m.unaligned.fused, m.unaligned.fused_lag, worst_revised);

  // configure() must reset every piece of state: a partial run (23 frames: the tracking audit's
  // phase, the gates' windows, the odometry map all mid-way) followed by the full run again gives
  // the first run's bits. (It once did not: the audit phase survived and changed later rows.)
  const LocalizerCounters first_counters = stats.counters;
  eval::RunOptions partial = options;
  partial.max_frames = 23;
  std::vector<eval::FrameRecord> scratch, again;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, partial, scratch, stats, error)) << error;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, options, again, stats, error)) << error;
  ASSERT_EQ(again.size(), records.size());
  int audits_first = 0, audits_again = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    audits_first += records[i].out.basin_audited ? 1 : 0;
    audits_again += again[i].out.basin_audited ? 1 : 0;
  }
  std::printf("audits: first run %d, after a partial run %d\n", audits_first, audits_again);
  EXPECT_EQ(stats.counters.basin_audits, first_counters.basin_audits);
  EXPECT_EQ(stats.counters.global_searches, first_counters.global_searches);
  EXPECT_EQ(stats.counters.tracking_registrations, first_counters.tracking_registrations);
  EXPECT_EQ(stats.counters.registrations_fused, first_counters.registrations_fused);
  for (std::size_t i = 0; i < records.size(); ++i) {
    EXPECT_TRUE(again[i].out.fused_pose.matrix() == records[i].out.fused_pose.matrix()) << "frame " << i;
    EXPECT_EQ(again[i].out.registration_status, records[i].out.registration_status) << "frame " << i;
    EXPECT_EQ(again[i].out.basin_audited, records[i].out.basin_audited) << "frame " << i;
  }

  // Filter restarts at late registrations: with a registration NIS gate nothing passes, every
  // filter.reset_after_rejections-th fixed-lag registration (w/2 frames old) restarts the filter. The
  // restart must land at the current frame (the registration carried forward by the odometry):
  // restarting at the registration's own time left that frame's output ~3 m behind.
  eval::RunOptions restarts = options;
  restarts.params.filter.ekf.gates.registration_nis_threshold = 1e-12;
  std::vector<eval::FrameRecord> restarted;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, restarts, restarted, stats, error)) << error;
  EXPECT_GE(stats.counters.filter_resets, 3u);
  double worst_restarted = 0.0;
  for (const eval::FrameRecord& r : restarted) {
    if (!r.out.filter_initialized) continue;
    const Eigen::Vector3d e = r.out.fused_pose.translation() - r.truth.translation();
    worst_restarted = std::max(worst_restarted, e.norm());
  }
  std::printf("restarts %u, worst error after initialization %.3f m\n", stats.counters.filter_resets,
              worst_restarted);
  EXPECT_LT(worst_restarted, 0.25);

  // The start-up search spread over the periods (the ECU's bounded mode): its result comes some
  // frames after it started, the best pose refined so far is output meanwhile (on the map, not
  // flagged localized), the filter starts within 20 frames and the revised start-up frames and
  // the gate-valid frames are as good as with the search in one period.
  eval::RunOptions spread = options;
  spread.params.startup.work_per_period = 80000;  // a tenth of the default: several periods
  spread.params.startup.first_work_per_period = 0;  // the first acquisition on that quota too
  std::vector<eval::FrameRecord> spread_records;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, spread, spread_records, stats, error)) << error;
  int first_result = -1, first_on_map = -1, spread_first = -1;
  for (std::size_t i = 0; i < spread_records.size(); ++i) {
    const eval::FrameRecord& r = spread_records[i];
    const double e = (r.out.fused_pose.translation() - r.truth.translation()).norm();
    if (first_result < 0 && r.out.searched) first_result = static_cast<int>(i);
    if (first_on_map < 0 && e < 0.5) first_on_map = static_cast<int>(i);
    if (spread_first < 0 && r.out.filter_initialized) spread_first = static_cast<int>(i);
  }
  const eval::RowMetrics sm = eval::compute_metrics(spread_records);
  std::printf("spread search: first result %d, first output on the map %d, filter from %d, fused %.3f m, "
              "fused (lag) %.4f m, fused (valid) %.4f m\n", first_result, first_on_map, spread_first,
              sm.unaligned.fused, sm.unaligned.fused_lag, sm.unaligned.fused_valid);
  EXPECT_GE(first_result, 1) << "a one-period search would report at frame 0";
  ASSERT_GE(first_on_map, 0);
  EXPECT_LE(first_on_map, 10);
  ASSERT_GE(spread_first, 0);
  EXPECT_LE(spread_first, 20);
  EXPECT_LT(sm.unaligned.fused_lag, 0.05);
  EXPECT_LT(sm.unaligned.fused_valid, 0.05);
  EXPECT_GT(sm.valid_frames, 10);

  // A period budget with no room (the period-work estimate says every period is full): rebuild
  // steps wait, but never more than max_deferred_rebuild_steps in a row, so the map still
  // refreshes; the audit never starts; a pose comes out every frame and the track holds.
  eval::RunOptions starved = options;
  starved.params.work.budget = 1.0;
  // (The first acquisition has no room either: its first slice scores, climbs and refines the
  // best hypothesis' coarse pose whatever the budget, the search's floor carries the rest.)
  std::vector<eval::FrameRecord> starved_records;
  ASSERT_TRUE(eval::run_offline(reader, g_localizer, starved, starved_records, stats, error)) << error;
  ASSERT_EQ(starved_records.size(), 50u);
  const eval::RowMetrics tm = eval::compute_metrics(starved_records);
  std::printf("no period room: rebuild steps deferred %u, map rebuilds %u, audits %u, fused (valid) %.4f m\n",
              stats.counters.rebuild_steps_deferred, stats.counters.map_rebuilds, stats.counters.basin_audits,
              tm.unaligned.fused_valid);
  EXPECT_GT(stats.counters.rebuild_steps_deferred, 0u);
  EXPECT_GT(stats.counters.map_rebuilds, 1u) << "deferral is bounded: the map is rebuilt";
  EXPECT_EQ(stats.counters.basin_audits, 0u);
  EXPECT_LT(tm.unaligned.fused_valid, 0.05);
  EXPECT_GT(tm.valid_frames, 10);
  std::filesystem::remove_all(dir);
}

// The localizer's own calls allocate nothing once configured (the test harness around it may).
TEST(LocalizerScenario, NoHeapAllocationPerFrame) {
  const GeodeticOrigin origin = make_geodetic_origin(48.1374, 11.5755, 520.0);
  g_localizer.configure(LocalizerParams{}, origin);
  static Vec3f scan[20000];
  static float times[20000];
  for (int i = 0; i < 20000; ++i) {
    const double a = i * 0.0137;
    scan[i] = Vec3f(static_cast<float>(10.0 * det::cos(a)), static_cast<float>(10.0 * det::sin(a)),
                    static_cast<float>((i % 64) * 0.1 - 1.5));
    times[i] = static_cast<float>((i % 1000) * 1e-4);
  }
  static Vec3f cloud[5000];
  for (int i = 0; i < 5000; ++i) {
    cloud[i] = Vec3f(static_cast<float>(i % 50), static_cast<float>((i / 50) % 50), static_cast<float>(i % 7));
  }
  std::uint64_t allocations = 0;
  {
    const firmware::alloc_counter::Scope counting;
    for (int f = 0; f < 5; ++f) {
      const double t = 0.1 * f;
      g_localizer.on_vehicle(VehicleInput{t, 5.0, 0.01});
      GnssInput g;
      g.t = t;
      g.lat_deg = 48.1374;
      g.lon_deg = 11.5755;
      g.alt_m = 520.0;
      g.h_acc = 5.0;
      g.v_acc = 8.0;
      g.valid = true;
      g_localizer.on_gnss(g);
      MapCloudInput m;
      m.source_id = 1;
      m.t = t;
      m.points = std::span<const Vec3f>(cloud, 5000);
      g_localizer.on_map_cloud(m);
      EgoScanInput in;
      in.t = t;
      in.points = std::span<const Vec3f>(scan, 20000);
      in.point_times = std::span<const float>(times, 20000);
      g_localizer.on_ego_scan(in);
    }
    allocations = counting.allocations();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(g_localizer.counters().frames, 5u);
}

}  // namespace
}  // namespace v2xloc

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
