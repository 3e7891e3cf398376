// Adversarial 100 ms periods through the whole localizer (CAN-rate vehicle signals, a GNSS fix,
// map clouds, the ego scan), each asserting a finite pose out every frame and the counters that
// show the input was handled (drops counted, not crashes). The instruction budget per period
// (100 M, an A53-class core at 10 Hz) is asserted by tools/timing/worst_case_instructions.py,
// which runs this binary under callgrind: every period is bracketed by stats dumps labelled
// "CASE period N" (set-up work is labelled "setup" and not counted).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "firmware/wire/share_schedule.hpp"
#include "tests/worst_case/localizer/worst_case_scene.hpp"
#include "tools/target/fixture_writer.hpp"
#include "v2xloc/algo/core/geodesy.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define WC_DUMP(label) CALLGRIND_DUMP_STATS_AT(label)
#define WC_UNDER_VALGRIND() (RUNNING_ON_VALGRIND != 0)
#else
#define WC_DUMP(label) ((void)(label))
#define WC_UNDER_VALGRIND() false
#endif

namespace v2xloc::worst_case {
namespace {

Localizer g_localizer;  // hundreds of MB: static
// With V2XLOC_TARGET_FIXTURE=FILE, AdversarialPeriods also writes its drive as a target fixture
// (docs/target.md): every localizer input, counted periods labelled with their case, the others "setup".
fixture::FixtureWriter* g_fixture = nullptr;

// Under callgrind, a counted period is dumped stage by stage ("CASE period N STAGE"), so the
// script can name the stage that spent a period's instructions.
struct StageDumps {
  const char* period = nullptr;  // "CASE period N" while a counted period runs, else nullptr
  LocalizerStage current = LocalizerStage::kIdle;
  static void on_mark(void* self, LocalizerStage s) { static_cast<StageDumps*>(self)->mark(s); }
  void mark(LocalizerStage s) {
    if (period != nullptr) {
      char label[128];
      std::snprintf(label, sizeof label, "%s %s", period, stage_name(current));
      WC_DUMP(label);
    }
    current = s;
  }
};
StageDumps g_stage_dumps;

constexpr double kSpeed = 5.0;      // [m/s] along +x
constexpr double kLidarHeight = 1.8;

struct Period {
  std::vector<Vec3f> scan;                 // LiDAR frame; empty: the canyon seen from the truth
  std::vector<float> times;                // per point, optional
  double scan_t_offset = 0.0;              // added to the frame time (time going backwards)
  Vec3d gnss_error = Vec3d::Zero();        // [m] fix = truth + this
  std::vector<MapCloudInput> clouds;
};

class Drive {
 public:
  explicit Drive(std::string name, Scene scene = Scene::kCanyon, const LocalizerParams& params = {})
      : name_(std::move(name)), scene_(scene) {
    WC_DUMP("setup");
    origin_ = make_geodetic_origin(48.137, 11.575, 520.0);
    g_localizer.configure(params, origin_);
    if (g_fixture != nullptr) g_fixture->configure(48.137, 11.575, 520.0);
    g_localizer.set_stage_probe(StageProbe{&StageDumps::on_mark, &g_stage_dumps});
    map_world_ = scene_points(scene_, Vec3d(0.0, 0.0, 0.0), 60.0, 0.2);
    infra_pose_ = pose_xy_yaw(0.0, 11.0, 5.0, 0.0);
    infra_cloud_ = to_sensor(map_world_, infra_pose_, config::kMaxScanPoints);
  }

  void set_name(std::string name) {
    name_ = std::move(name);
    period_ = 0;
  }
  Mat4d truth() const { return pose_xy_yaw(-20.0 + kSpeed * t_, 0.0, 0.0, 0.0); }
  Mat4d body_T_lidar() const { return pose_xy_yaw(0.0, 0.0, kLidarHeight, 0.0); }

  // The ego scan of the scene from the current truth (<= max_points, 60 m).
  std::vector<Vec3f> canyon_scan(std::size_t max_points = 60000) const {
    const Mat4d world_T_lidar = truth() * body_T_lidar();
    const std::vector<Vec3d> world = scene_points(scene_, world_T_lidar.topRightCorner<3, 1>(), 50.0, 0.25);
    return to_sensor(world, world_T_lidar, max_points);
  }

  MapCloudInput infra_cloud(std::uint32_t id = 1) const {
    MapCloudInput in;
    in.source_id = id;
    in.t = t_;
    in.world_T_sensor = infra_pose_;
    in.points = std::span<const Vec3f>(infra_cloud_.data(), infra_cloud_.size());
    return in;
  }

  // One 100 ms period; returns the frame output. counted: bracketed by callgrind dumps.
  const LocalizerFrameOutput& run(Period p, bool counted) {
    const auto started = std::chrono::steady_clock::now();
    t_ += 0.1;
    if (p.scan.empty()) p.scan = canyon_scan();
    for (MapCloudInput& c : p.clouds) c.t = t_;
    char label[96];
    std::snprintf(label, sizeof label, "%s period %d", name_.c_str(), period_);
    WC_DUMP("setup");
    g_stage_dumps.current = LocalizerStage::kIdle;
    g_stage_dumps.period = counted ? label : nullptr;
    if (g_fixture != nullptr) g_fixture->label(counted ? name_ : "setup");
    for (int k = 0; k < 10; ++k) {
      VehicleInput v;
      v.t = t_ - 0.09 + 0.01 * k;
      v.wheel_speed = kSpeed;
      v.yaw_rate = 0.0;
      if (g_fixture != nullptr) g_fixture->vehicle(v);
      g_localizer.on_vehicle(v);
    }
    const Vec3d fix = truth().topRightCorner<3, 1>() + p.gnss_error;
    const EcefToGeodeticResult g = enu_to_geodetic(origin_, fix);
    GnssInput gi;
    gi.t = t_;
    gi.lat_deg = g.point.lat_deg;
    gi.lon_deg = g.point.lon_deg;
    gi.alt_m = g.point.alt_m;
    gi.h_acc = 5.0;
    gi.v_acc = 8.0;
    gi.num_sats = 9;
    gi.hdop = 1.2;
    gi.valid = true;
    if (g_fixture != nullptr) g_fixture->gnss(gi);
    g_localizer.on_gnss(gi);
    deliver_map_clouds(p.clouds);
    EgoScanInput in;
    in.t = t_ + p.scan_t_offset;
    in.points = std::span<const Vec3f>(p.scan.data(), p.scan.size());
    if (p.times.size() == p.scan.size()) in.point_times = std::span<const float>(p.times.data(), p.times.size());
    in.body_T_lidar = body_T_lidar();
    if (g_fixture != nullptr) g_fixture->ego_scan(in);
    const LocalizerFrameOutput& out = g_localizer.on_ego_scan(in);
    ++frames_;
    if (counted && !WC_UNDER_VALGRIND()) {  // host wall time of the period (inputs, map clouds, scan)
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
      std::printf("host ms: %s period %d %.2f\n", name_.c_str(), period_, ms);
    }
    if (counted) {
      g_stage_dumps.mark(LocalizerStage::kIdle);  // the rest of the period
      ++period_;
    } else {
      WC_DUMP("setup");
    }
    g_stage_dumps.period = nullptr;
    EXPECT_TRUE(out.fused_pose.matrix().allFinite()) << name_ << " frame " << out.frame;
    EXPECT_TRUE(std::isfinite(out.sigma_x) && std::isfinite(out.sigma_y)) << name_;
    return out;
  }

  // Warm-up: the map and a few frames of the plain canyon (not counted).
  void warm_up(int frames) {
    for (int i = 0; i < frames; ++i) {
      Period p;
      p.clouds.push_back(infra_cloud());
      run(std::move(p), false);
    }
  }
  // Past power-up (counted on its own: PowerUpFirstAcquisition): the adversarial periods come
  // after the first acquisition.
  void past_first_acquisition() {
    while (frames_ < static_cast<int>(g_localizer.params().startup.first_frames)) warm_up(1);
  }
  // ... and, for the cases that need one, a localizer that has tracked for kSettledFrames (the
  // synthetic canyon repeats itself along the street: a start may be an alias the basin audit
  // leaves at once).
  void settle_track() {
    int tracked = 0;
    for (int i = 0; i < kMaxSettleFrames && tracked < kSettledFrames; ++i) {
      Period p;
      p.clouds.push_back(infra_cloud());
      tracked = run(std::move(p), false).mode == LocalizationMode::kTracking ? tracked + 1 : 0;
    }
    EXPECT_GE(tracked, kSettledFrames) << name_ << ": no settled track after " << frames_ << " frames";
  }
  static constexpr int kMaxSettleFrames = 80;
  static constexpr int kSettledFrames = 3;

  // Map clouds reach the localizer as the firmware hands them over (firmware/wire/share_schedule.hpp):
  // queued as they arrive (the oldest gives way past the queue's capacity), at most
  // kMaxSignatureVerificationsPerPeriod a period and no more than the localizer asks for
  // (map_clouds_per_period); shares it would not fuse (paced) are skipped before the budget.
  void deliver_map_clouds(const std::vector<MapCloudInput>& arrived) {
    for (const MapCloudInput& c : arrived) {
      const firmware::ShareSchedule::Admission a = schedule_.admit();
      if (a.dropped_oldest) ++shares_dropped_;
      waiting_[a.slot] = c;
    }
    schedule_.begin_period();
    const std::size_t budget = firmware::shares_this_period(g_localizer.map_clouds_per_period());
    std::size_t fused = 0, slot = 0;
    for (std::size_t k = 0; k < firmware::kShareVerifyQueueCapacity && fused < budget && schedule_.release(slot); ++k) {
      if (!g_localizer.wants_map_cloud(waiting_[slot].source_id, waiting_[slot].t)) {
        schedule_.refund();
        continue;
      }
      if (g_fixture != nullptr) g_fixture->map_cloud(waiting_[slot]);
      g_localizer.on_map_cloud(waiting_[slot]);
      ++fused;
    }
  }

  std::size_t shares_dropped() const { return shares_dropped_; }
  std::size_t shares_waiting() const { return schedule_.waiting(); }

 private:
  firmware::ShareSchedule schedule_;
  MapCloudInput waiting_[firmware::ShareSchedule::kCapacity];  // spans into clouds the test keeps alive
  std::size_t shares_dropped_ = 0;
  std::string name_;
  Scene scene_;
  GeodeticOrigin origin_{};
  double t_ = 0.0;
  int period_ = 0;
  int frames_ = 0;  // periods run since configure()
  std::vector<Vec3d> map_world_;
  Mat4d infra_pose_ = Mat4d::Identity();
  std::vector<Vec3f> infra_cloud_;
};

// One drive through every adversarial input (one warm-up, so the run stays cheap under
// callgrind); a plain period between cases lets the localizer recover, uncounted.
TEST(WorstCase, AdversarialPeriods) {
  fixture::FixtureWriter writer;
  if (const char* path = std::getenv("V2XLOC_TARGET_FIXTURE")) {
    ASSERT_TRUE(writer.open(path)) << path;
    g_fixture = &writer;
  }
  struct Detach {
    ~Detach() { g_fixture = nullptr; }
  } detach;
  Drive d("setup");
  d.warm_up(3);
  d.past_first_acquisition();
  d.settle_track();

  {  // A full-size sweep is read whole (ingest keeps voxels, not returns) ...
    d.set_name("max_capacity_scan");
    Period p;
    const std::vector<Vec3f> base = d.canyon_scan();
    const std::size_t want = config::kMaxScanPoints + 1000;
    for (std::size_t i = 0; p.scan.size() < want; ++i) {
      const float jitter = 0.001f * static_cast<float>(i / base.size());
      p.scan.push_back(base[i % base.size()] + Vec3f(jitter, 0.0f, 0.0f));
    }
    d.run(std::move(p), true);
    d.run(Period{}, false);
  }
  {  // ... and more occupied voxels than the ingest holds: the sweep is read again with a coarser
     // voxel (counted) rather than cut in firing order; what still does not fit is dropped and counted.
    d.set_name("voxel_capacity_scan");
    Period p;
    const int side = 40;  // 64000 occupied 0.5 m voxels > kMaxDownsampledPoints
    for (int i = 0; i < side; ++i)
      for (int j = 0; j < side; ++j)
        for (int k = 0; k < side; ++k) p.scan.emplace_back(4.25f + 0.5f * i, -9.75f + 0.5f * j, -1.75f + 0.5f * k);
    const std::uint32_t coarsened_before = g_localizer.counters().scans_coarsened;
    d.run(std::move(p), true);
    EXPECT_EQ(g_localizer.counters().scans_coarsened - coarsened_before, 1u);
    d.run(Period{}, false);
  }
  {
    d.set_name("identical_points");
    Period p;
    p.scan.assign(config::kMaxScanPoints, Vec3f(10.0f, 2.0f, -1.0f));
    d.run(std::move(p), true);
    d.run(Period{}, false);
  }
  {
    d.set_name("one_plane");
    Period p;
    for (float x = -40.0f; x <= 40.0f; x += 0.25f) {
      for (float y = -40.0f; y <= 40.0f; y += 0.25f) p.scan.emplace_back(x, y, -kLidarHeight);
    }
    d.run(std::move(p), true);
    d.run(Period{}, false);
  }
  {
    d.set_name("one_line");
    Period p;
    for (int i = 0; i < 60000; ++i) p.scan.emplace_back(4.0f + 0.001f * i, 3.0f, 0.5f);
    d.run(std::move(p), true);
    d.run(Period{}, false);
  }
  {
    d.set_name("pure_noise");
    Period p;
    Rng rng(11);
    for (int i = 0; i < 100000; ++i) {
      p.scan.emplace_back(static_cast<float>(160.0 * rng.uniform() - 80.0),
                          static_cast<float>(160.0 * rng.uniform() - 80.0),
                          static_cast<float>(30.0 * rng.uniform() - 5.0));
    }
    d.run(std::move(p), true);
    d.run(Period{}, false);
  }
  {
    d.set_name("half_nan_inf");
    Period p;
    p.scan = d.canyon_scan();
    const float bad[3] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                          -std::numeric_limits<float>::infinity()};
    for (std::size_t i = 0; i < p.scan.size(); i += 2) p.scan[i][static_cast<int>(i / 2 % 3)] = bad[i / 2 % 3];
    const std::uint32_t dropped_before = g_localizer.counters().scan_points_dropped;
    const std::size_t n = p.scan.size();
    d.run(std::move(p), true);
    EXPECT_GE(g_localizer.counters().scan_points_dropped - dropped_before, static_cast<std::uint32_t>(n / 2));
    d.run(Period{}, false);
  }
  {
    d.set_name("time_backwards");
    Period p;
    p.scan_t_offset = -0.5;
    const LocalizerFrameOutput& out = d.run(std::move(p), true);
    EXPECT_FALSE(out.registration_attempted);  // an old frame is not processed, still answered
    d.run(Period{}, true);
  }
  {
    d.set_name("gnss_jump_100m");
    for (int i = 0; i < 3; ++i) {
      Period p;
      p.gnss_error = Vec3d(100.0, 0.0, 0.0);
      d.run(std::move(p), true);
    }
    d.run(Period{}, true);
  }
  {  // Every source slot (and one more) sends a full cloud in the same period; then the rebuild. The
     // firmware's queue keeps the newest kShareVerifyQueueCapacity (the rest dropped, counted) and
     // hands them over a few a period. Shares still waiting from before (the localizer takes none
     // while the first acquisition is pending) count towards the queue.
    d.set_name("map_capacity_all_sources");
    const std::vector<Vec3d> world = scene_points(Scene::kCanyon, Vec3d(0.0, 0.0, 0.0), 60.0, 0.15);
    std::vector<std::vector<Vec3f>> clouds;
    Period p;
    for (std::uint32_t s = 0; s <= config::kMaxMapSources; ++s) {
      const Mat4d pose = pose_xy_yaw(-40.0 + 5.0 * s, s % 2 ? 11.0 : -11.0, 5.0, 0.0);
      clouds.push_back(to_sensor(world, pose, config::kMaxScanPoints));
    }
    for (std::uint32_t s = 0; s <= config::kMaxMapSources; ++s) {
      MapCloudInput in;
      in.source_id = 100 + s;
      in.world_T_sensor = pose_xy_yaw(-40.0 + 5.0 * s, s % 2 ? 11.0 : -11.0, 5.0, 0.0);
      in.points = std::span<const Vec3f>(clouds[s].data(), clouds[s].size());
      p.clouds.push_back(in);
    }
    const std::size_t backlog = d.shares_waiting();
    const std::size_t dropped_before = d.shares_dropped();
    d.run(std::move(p), true);
    for (int i = 0; i < 6; ++i) d.run(Period{}, true);
    EXPECT_EQ(d.shares_dropped() - dropped_before,
              backlog + config::kMaxMapSources + 1 - firmware::kShareVerifyQueueCapacity);
    std::size_t sources = 0;
    for (const MapSourceInfo& src : g_localizer.map().sources()) sources += src.active ? 1 : 0;
    EXPECT_GE(sources, 2u) << "the queued shares reached the map";
  }
  if (g_fixture != nullptr) {
    EXPECT_TRUE(writer.close()) << "writing the target fixture";
  }
}

// Power-up: the first map and the first acquisition's search counted from the first period.
// Default (startup.first_work_per_period 0): within the budget, the search's first slice scores
// and climbs every hypothesis and every period fits. The opt-in power-up exemption (1.5M units a
// period) runs the whole search in period 0, over the budget (a known gap: InstructionBudget's
// ceiling). A pose comes out every frame in both.
TEST(WorstCase, PowerUpFirstAcquisition) {
  for (const bool exempt : {true, false}) {
    LocalizerParams params;
    params.startup.first_work_per_period = exempt ? 1500000u : 0u;
    Drive d(exempt ? "power_up_exempt" : "power_up_within_budget", Scene::kCanyon, params);
    for (int i = 0; i < 6; ++i) {
      Period p;
      p.clouds.push_back(d.infra_cloud());
      d.run(std::move(p), true);
    }
  }
}

TEST(WorstCase, FeaturelessCorridor) {
  Drive d("setup", Scene::kCorridor);
  d.warm_up(1);
  d.past_first_acquisition();
  d.set_name("featureless_corridor");
  for (int i = 0; i < 3; ++i) d.run(Period{}, true);
}

TEST(WorstCase, LostTrackSearchedFrom30mWrongFix) {
  Drive d("setup");
  d.warm_up(1);  // brings the map
  d.past_first_acquisition();
  d.settle_track();
  // The track is lost: scans with nothing in range (a blinded LiDAR) while the fix drifts 30 m
  // off, until the localizer searches again (uncounted; bounded).
  bool searching = false;
  for (int i = 0; i < 40 && !searching; ++i) {
    Period p;
    p.scan.assign(1, Vec3f(1000.0f, 0.0f, 0.0f));  // beyond max_range: an empty sweep
    p.gnss_error = Vec3d(30.0, 0.0, 0.0);
    searching = d.run(std::move(p), false).mode == LocalizationMode::kGlobalSearch;
  }
  ASSERT_TRUE(searching) << "the blinded track was never searched again";
  d.set_name("search_from_30m_wrong_fix");
  // The LiDAR back, GNSS still 30 m off: the periods until the track is found run the search.
  int searched = 0;
  for (int i = 0; i < 4; ++i) {
    Period p;
    p.clouds.push_back(d.infra_cloud());
    p.gnss_error = Vec3d(30.0, 0.0, 0.0);
    searched += d.run(std::move(p), true).mode == LocalizationMode::kGlobalSearch ? 1 : 0;
  }
  EXPECT_GE(searched, 1);
}

}  // namespace
}  // namespace v2xloc::worst_case
