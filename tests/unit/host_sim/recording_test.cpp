#include "host_sim/recording/pcd_export.hpp"
#include "host_sim/recording/recorder.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/cloud_io/pcd.hpp"
#include "firmware/protocol/can_messages.hpp"
#include "firmware/trust/background_file.hpp"
#include "v2xloc/algo/localization/surveyed_background.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

namespace v2xloc::sim {
namespace {

#include <unistd.h>

namespace fs = std::filesystem;

// One folder per test process: ctest runs each TEST as its own process, two at a time.
std::string tmp_dir(const std::string& name) {
  const fs::path p = fs::path(V2XLOC_BINARY_DIR) / "test_tmp" / "host_sim" /
                     (name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

std::vector<char> slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

RecorderConfig quick_config(const std::string& dir, std::uint64_t seed) {
  RecorderConfig c;
  c.scenario = 3;
  c.permutation = Permutation::k4Infra2Agent;
  c.seed = seed;
  c.quick = true;
  c.duration = 1.0;
  c.out_dir = dir;
  return c;
}

class HostSimRecording : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_a_ = tmp_dir("rec_a");
    dir_b_ = tmp_dir("rec_b");
    dir_c_ = tmp_dir("rec_c");
    std::string err;
    ok_ = generate_recording(quick_config(dir_a_, 11), sum_a_, err) &&
          generate_recording(quick_config(dir_b_, 11), sum_b_, err) &&
          generate_recording(quick_config(dir_c_, 12), sum_c_, err);
    error_ = err;
  }
  static inline std::string dir_a_, dir_b_, dir_c_, error_;
  static inline RecordingSummary sum_a_, sum_b_, sum_c_;
  static inline bool ok_ = false;
};

TEST_F(HostSimRecording, SameSeedGivesByteIdenticalRecording) {
  ASSERT_TRUE(ok_) << error_;
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir_a_)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), dir_a_);
    ASSERT_TRUE(fs::exists(fs::path(dir_b_) / rel)) << rel;
    EXPECT_EQ(slurp(e.path()), slurp(fs::path(dir_b_) / rel)) << rel;
    ++files;
  }
  EXPECT_GT(files, 20u);
}

TEST_F(HostSimRecording, DifferentSeedGivesDifferentNoise) {
  ASSERT_TRUE(ok_) << error_;
  EXPECT_NE(slurp(fs::path(dir_a_) / "ego_lidar/000000.pcdz"), slurp(fs::path(dir_c_) / "ego_lidar/000000.pcdz"));
  EXPECT_NE(slurp(fs::path(dir_a_) / "stereo/000000.png"), slurp(fs::path(dir_c_) / "stereo/000000.png"));
}

TEST_F(HostSimRecording, ReaderIteratesFramesCloudsAndTruth) {
  ASSERT_TRUE(ok_) << error_;
  RecordingReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir_a_, err)) << err;
  EXPECT_EQ(r.frame_count(), 10);
  EXPECT_EQ(r.scenario(), 3);
  EXPECT_EQ(r.permutation(), "4_infra_2_agent");
  ASSERT_EQ(r.ground_truth().size(), 10u);
  EXPECT_EQ(r.ground_truth_100hz().size(), 100u);
  for (int i = 0; i < r.frame_count(); ++i) {
    cloud_io::PointCloud scan;
    ASSERT_TRUE(r.ego_scan(i, scan, err)) << err;
    ASSERT_TRUE(scan.has_time());
    ASSERT_TRUE(scan.has_intensity());
    EXPECT_GT(scan.size(), 16u * 256u / 2u);  // quick ego LiDAR: 16 x 256 rays
    EXPECT_LE(scan.size(), 16u * 256u);
    for (float t : scan.time) {
      EXPECT_GE(t, 0.0f);
      EXPECT_LT(t, 0.1f);
    }
    EXPECT_NEAR(r.ground_truth()[static_cast<std::size_t>(i)].t, r.frame_time(i), 1e-9);
    Image16 disp;
    ASSERT_TRUE(r.disparity(i, disp, err)) << err;
    EXPECT_EQ(disp.width, r.stereo_calibration().width);
  }
  // 2 Hz map clouds over 1 s: stamps 0.0 and 0.5, 4 infra + 2 agents each.
  EXPECT_EQ(r.map_clouds().size(), 12u);
  EXPECT_EQ(r.latest_map_clouds(0.7).size(), 6u);
  EXPECT_EQ(r.map_clouds_until(0.2).size(), 6u);
  EXPECT_EQ(r.infra_surveyed_poses().size(), 4u);
  for (const auto& m : r.map_clouds()) {
    cloud_io::PointCloud c;
    ASSERT_TRUE(r.load_map_cloud(m, c, err)) << err;
    EXPECT_EQ(c.size(), m.points);
    if (m.kind == "infra") {
      EXPECT_TRUE(m.sensor_pose.isApprox(m.true_sensor_pose));
    }
    if (m.kind == "agent") {
      const double e = (m.sensor_pose.translation() - m.true_sensor_pose.translation()).norm();
      EXPECT_GT(e, 0.0);
      EXPECT_LT(e, 0.5);  // small self-localization error
    }
  }
  // Ground truth interpolation agrees with the frame truth.
  EXPECT_TRUE(r.ground_truth_at(0.5).isApprox(r.ground_truth()[5].pose, 1e-6));
}

// export-pcd: every cloud as a standard float32 PCD (what PCL writes) with the values the reader
// returns from the quantised files, at the manifest's paths.
TEST_F(HostSimRecording, ExportWritesStandardPcdWithTheReadersValues) {
  ASSERT_TRUE(ok_) << error_;
  RecordingReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir_a_, err)) << err;
  const std::string out = tmp_dir("export");
  PcdExportSummary summary;
  ASSERT_TRUE(export_recording_pcd(r, out, cloud_io::PcdEncoding::kBinaryCompressed, summary, err)) << err;
  EXPECT_EQ(summary.clouds, r.frame_count() + static_cast<int>(r.map_clouds().size()));
  const std::vector<char> head = slurp(fs::path(out) / "ego_lidar/000003.pcd");
  const std::string header(head.begin(), head.begin() + std::min<std::size_t>(head.size(), 400));
  EXPECT_NE(header.find("TYPE F F F F F\n"), std::string::npos) << header;
  EXPECT_NE(header.find("DATA binary_compressed\n"), std::string::npos) << header;
  EXPECT_EQ(header.find("SCALE"), std::string::npos) << header;
  cloud_io::PointCloud expected, exported;
  ASSERT_TRUE(r.ego_scan(3, expected, err)) << err;
  ASSERT_TRUE(cloud_io::read_pcd((fs::path(out) / "ego_lidar/000003.pcd").string(), exported, err)) << err;
  EXPECT_EQ(exported.points, expected.points);
  EXPECT_EQ(exported.intensity, expected.intensity);
  EXPECT_EQ(exported.time, expected.time);
  const MapCloudInfo& last = r.map_clouds().back();
  fs::path map_pcd = fs::path(out) / last.file;
  map_pcd.replace_extension(".pcd");
  ASSERT_TRUE(r.load_map_cloud(last, expected, err)) << err;
  ASSERT_TRUE(cloud_io::read_pcd(map_pcd.string(), exported, err)) << err;
  EXPECT_EQ(exported.points, expected.points);
  fs::remove_all(out);
}

TEST_F(HostSimRecording, EgoScanGeometryMatchesTheWorldViaGroundTruth) {
  ASSERT_TRUE(ok_) << error_;
  RecordingReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir_a_, err)) << err;
  cloud_io::PointCloud scan;
  ASSERT_TRUE(r.ego_scan(4, scan, err)) << err;
  // Points classified as ground (world z near 0 after deskew with truth) must be numerous.
  std::size_t ground = 0;
  for (std::size_t k = 0; k < scan.size(); ++k) {
    const Eigen::Isometry3d T = r.ground_truth_at(r.frame_time(4) + scan.time[k]) * r.ego_lidar_mount();
    const Eigen::Vector3d w = T * scan.points[k].cast<double>();
    ground += std::abs(w.z()) < 0.1 ? 1 : 0;
  }
  EXPECT_GT(ground, scan.size() / 4);
}

TEST_F(HostSimRecording, CanLogHoldsVehicleAndGnssFramesInTimeOrder) {
  ASSERT_TRUE(ok_) << error_;
  RecordingReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir_a_, err)) << err;
  ASSERT_FALSE(r.can_log_path().empty());
  std::vector<CanLogFrame> frames;
  ASSERT_TRUE(r.can_frames(frames, err)) << err;
  std::size_t motion = 0, gnss = 0;
  double last = -1;
  for (const auto& f : frames) {
    EXPECT_GE(f.t, last - 1e-9);
    last = f.t;
    motion += f.id == 0x120 ? 1 : 0;
    gnss += (f.id >= 0x130 && f.id <= 0x134) ? 1 : 0;
    EXPECT_EQ(f.dlc, 8);
    // Layout 2: every frame carries its CRC in byte 7.
    EXPECT_EQ(f.data[7], protocol::frame_crc(f.id, f.data)) << std::hex << f.id;
  }
  EXPECT_EQ(motion, 100u);  // 100 Hz over 1 s
  EXPECT_GE(gnss, 20u);     // 5 Hz x (status + velocity + DOP + time [+ latitude + longitude])
  EXPECT_LT(last, 1.0);
}

// Every infrastructure unit's trust-list entry names its surveyed background beside the list,
// the file passes the firmware's checks (digest, sender, order, capacity), and every cloud the
// unit recorded (vehicles driving through its view) is consistent with it.
TEST_F(HostSimRecording, EveryInfrastructureUnitHasABackgroundItsCloudsMatch) {
  ASSERT_TRUE(ok_) << error_;
  RecordingReader r;
  std::string err;
  ASSERT_TRUE(r.open(dir_a_, err)) << err;
  EXPECT_EQ(r.seed(), 11u);
  EXPECT_TRUE(r.quick());
  trust::TrustList list;
  ASSERT_TRUE(load_trust_list(r.trust_list_path(), list, err)) << err;
  EXPECT_EQ(list.background_count(), 4u);
  std::size_t checked = 0;
  for (const trust::TrustedSigner& s : list.view()) {
    if (s.role != trust::SignerRole::kInfrastructure) continue;
    ASSERT_TRUE(s.has_background) << s.name.data();
    const std::vector<char> file = slurp(fs::path(dir_a_) / s.background_file.data());
    std::vector<std::uint32_t> cells(config::kBackgroundFileCells);
    trust::BackgroundInfo info;
    ASSERT_EQ(trust::parse_background({reinterpret_cast<const std::uint8_t*>(file.data()), file.size()}, s, cells, info),
              trust::BackgroundStatus::kOk)
        << s.background_file.data();
    const SurveyedBackground bg{info.cell_m, std::span<const std::uint32_t>(cells.data(), info.cells)};
    ASSERT_TRUE(background_valid(bg));
    for (const MapCloudInfo& m : r.map_clouds()) {
      if (m.sensor != s.name.data()) continue;
      cloud_io::PointCloud c;
      ASSERT_TRUE(r.load_map_cloud(m, c, err)) << err;
      const BackgroundScore score = check_background(bg, c.points, m.sensor_pose.linear().transpose(), {});
      EXPECT_TRUE(score.consistent) << m.file << ": fitness " << score.fitness << " best probe " << score.best_probe;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 8u);  // 4 units x 2 clouds
}

}  // namespace
}  // namespace v2xloc::sim
