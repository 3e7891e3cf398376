// A real cooperative drive: the DAIR-V2X-C example (../shared/data/dair_v2x_c_example, outside the
// repository for its licence) converted to a recording, then localized in process and through the
// firmware with the defaults of the simulated rows. Skipped with the reason where the data is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "host_sim/recording/recording_reader.hpp"
#include "tools/dataset/dair_recording.hpp"
#include "tools/eval/firmware_run.hpp"
#include "tools/eval/metrics.hpp"
#include "tools/eval/offline_run.hpp"
#include "v2xloc/algo/core/config.hpp"

namespace v2xloc {
namespace {

namespace fs = std::filesystem;

const std::string kRoot = std::string(V2XLOC_SOURCE_DIR) + "/../shared/data/dair_v2x_c_example";
const std::string kBin = std::string(V2XLOC_BINARY_DIR) + "/bin/";
Localizer g_localizer;  // host profile: tens of MB, never on the stack

// The vehicle LiDAR's pose in DAIR's world frame, composed here from the two calibration files of
// one scan (independently of the converter).
Eigen::Isometry3d dair_lidar_pose(const std::string& id) {
  const auto read = [](const std::string& path) {
    std::ifstream in(path);
    nlohmann::json j = nlohmann::json::parse(in);
    if (j.contains("transform")) j = j["transform"];
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) T.linear()(r, c) = j["rotation"][r][c].get<double>();
      T.translation()[r] = j["translation"][r][0].get<double>();
    }
    return T;
  };
  return read(kRoot + "/vehicle-side/calib/novatel_to_world/" + id + ".json") *
         read(kRoot + "/vehicle-side/calib/lidar_to_novatel/" + id + ".json");
}

class RealDrive : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::is_directory(kRoot)) return;
    dir_ = (fs::temp_directory_path() / ("v2xloc_real_drive_" + std::to_string(::getpid()))).string();
    dataset::DairRecordingOptions options;
    options.root = kRoot;
    options.out_dir = dir_;
    converted_ = dataset::write_dair_recording(options, summary_, error_);
  }
  static void TearDownTestSuite() {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  void SetUp() override {
    if (!fs::is_directory(kRoot)) GTEST_SKIP() << kRoot << " absent (the DAIR-V2X-C example lives outside the repository)";
    ASSERT_TRUE(converted_) << error_;
    ASSERT_TRUE(reader_.open(dir_, error_)) << error_;
  }

  static std::string dir_, error_;
  static bool converted_;
  static dataset::DairRecordingSummary summary_;
  sim::RecordingReader reader_;
};

std::string RealDrive::dir_, RealDrive::error_;
bool RealDrive::converted_ = false;
dataset::DairRecordingSummary RealDrive::summary_;

TEST_F(RealDrive, ConverterKeepsTheScansStampsAndPoses) {
  EXPECT_EQ(reader_.frame_count(), 42);
  EXPECT_EQ(summary_.roadside_clouds, 22);  // 24 released, 22 within the drive
  EXPECT_NEAR(summary_.first_roadside_s, 2.1577, 1e-3);
  EXPECT_DOUBLE_EQ(reader_.frame_time(0), 0.0);
  EXPECT_NEAR(reader_.frame_time(41), 4.098879, 1e-6);  // the scans' own stamps, not 41 / 10 Hz
  EXPECT_NEAR(reader_.time_origin_unix(), 1626240238.805763, 1e-6);
  // Ground truth = NovAtel pose * lidar_to_novatel, lowered by the mount, shifted by world_offset.
  std::ifstream in(dir_ + "/manifest.json");
  const nlohmann::json m = nlohmann::json::parse(in);
  const Eigen::Vector3d offset(m["source"]["world_offset"][0].get<double>(), m["source"]["world_offset"][1].get<double>(),
                               m["source"]["world_offset"][2].get<double>());
  for (const auto& [frame, id] : {std::pair{0, "015344"}, std::pair{41, "015385"}}) {
    const Eigen::Isometry3d lidar = dair_lidar_pose(id);
    const Eigen::Isometry3d truth = reader_.ground_truth()[frame].pose * reader_.ego_lidar_mount();
    EXPECT_LT((truth.translation() + offset - lidar.translation()).norm(), 1e-5) << id;
    EXPECT_LT((truth.linear() - lidar.linear()).norm(), 1e-6) << id;
  }
  EXPECT_NEAR(summary_.lidar_height_m, 1.97, 0.1);
  // Per-point times relative to each scan's stamp, inside the sweep.
  cloud_io::PointCloud scan;
  ASSERT_TRUE(reader_.ego_scan(10, scan, error_)) << error_;
  ASSERT_EQ(scan.time.size(), scan.points.size());
  EXPECT_GT(scan.points.size(), 55000u);
  float lo = 1.0f, hi = 0.0f;
  for (float t : scan.time) lo = std::min(lo, t), hi = std::max(hi, t);
  EXPECT_GE(lo, 0.0f);
  EXPECT_GT(hi, 0.09f);
  EXPECT_LT(hi, 0.1f);
  // Canyon-grade GNSS (the paper's 8-17 m band), every fix valid.
  EXPECT_EQ(summary_.gnss_valid_fixes, 21);
  EXPECT_GT(summary_.gnss_mean_h_error_m, 8.0);
  EXPECT_LT(summary_.gnss_mean_h_error_m, 17.0);
  ASSERT_EQ(reader_.map_clouds().size(), 22u);
  EXPECT_EQ(reader_.map_clouds().front().kind, "infra");
}

// Both paths: a pose every frame; the columns from the first roadside cloud (frame 22) on. The
// unaligned error's floor is the dataset's own vehicle-to-roadside calibration (~0.5-1.2 m).
// The in-process bounds below are the host profile's; the EMBEDDED profile (each scan read into
// 4,096 voxels, a 12,288-point map) meets the firmware test's and not those (docs/target.md): not
// met, so not asserted as if it were.

void expect_pose_every_frame(const std::vector<eval::FrameRecord>& records) {
  ASSERT_EQ(records.size(), 42u);
  for (const eval::FrameRecord& r : records) EXPECT_TRUE(r.out.fused_pose.matrix().allFinite()) << r.t;
}

TEST_F(RealDrive, InProcessLocalizesAtTheDatasetFloor) {
  if (config::kEmbeddedProfile) {
    GTEST_SKIP() << "host-profile accuracy; EMBEDDED in process on this drive: aligned Fused 0.108 m, "
                    "Fused (valid) 0.071 m over 7 frames, RPE 1 s 0.214 m (docs/target.md)";
  }
  eval::RunOptions options;
  options.quiet = true;
  reader_.gnss_antenna_in_body(options.gnss_antenna_in_body);
  std::vector<eval::FrameRecord> records;
  eval::RunStats stats;
  ASSERT_TRUE(eval::run_offline(reader_, g_localizer, options, records, stats, error_)) << error_;
  expect_pose_every_frame(records);
  const eval::RowMetrics m = eval::compute_metrics(records, reader_.map_clouds().front().stamp);
  EXPECT_EQ(m.frames_before_map, 22);
  // Measured: filter from frame 26, unaligned Fused 0.715 m, aligned 0.067 m, aligned Fused (valid)
  // 0.015 m over 7 valid frames, RPE 1 s 0.115 m, offset (0.65, 0.20) m spread 0.079 m.
  EXPECT_GE(m.first_initialized_frame, 22);
  EXPECT_LE(m.first_initialized_frame, 28);
  EXPECT_LT(m.unaligned.fused, 1.0);
  EXPECT_LT(m.aligned.fused, 0.09);
  EXPECT_GE(m.valid_frames, 3);
  EXPECT_LT(m.aligned.fused_valid, 0.05);
  EXPECT_LT(m.rpe_1s.fused, 0.12);
  EXPECT_LT(m.offset.spread, 0.15);
  EXPECT_GT(m.offset.mean.head<2>().norm(), 0.3);  // the calibration offset is real, not absorbed
  EXPECT_LT(m.offset.mean.head<2>().norm(), 1.2);
}

// Both profiles.
TEST_F(RealDrive, FirmwareLocalizesAtTheDatasetFloor) {
  eval::FirmwareRunOptions options;
  options.firmware_path = kBin + "v2xloc-firmware";
  options.quiet = true;
  reader_.gnss_antenna_in_body(options.gnss_antenna_in_body);
  std::vector<eval::FrameRecord> records;
  eval::RunStats stats;
  ASSERT_TRUE(eval::run_firmware(reader_, options, records, stats, error_)) << error_;
  expect_pose_every_frame(records);
  const eval::RowMetrics m = eval::compute_metrics(records, reader_.map_clouds().front().stamp);
  // Measured, host: filter from frame 29, unaligned Fused 0.799 m, aligned 0.132 m, aligned Fused
  // (valid) 0.011 m over 8 valid frames, RPE 1 s 0.233 m (the start-up poses sit 0.2-0.4 m off
  // the tracked ones), offset spread 0.059 m. EMBEDDED: filter from frame 26, 0.634 / 0.078 m,
  // 0.021 m over 9 frames, RPE 1 s 0.159 m, spread 0.100 m.
  EXPECT_LE(m.first_initialized_frame, 32);
  EXPECT_LT(m.unaligned.fused, 1.0);
  EXPECT_LT(m.aligned.fused, 0.2);
  EXPECT_GE(m.valid_frames, 3);
  EXPECT_LT(m.aligned.fused_valid, 0.05);
  EXPECT_LT(m.rpe_1s.fused, 0.35);
  EXPECT_LT(m.offset.spread, 0.15);
}

}  // namespace
}  // namespace v2xloc
