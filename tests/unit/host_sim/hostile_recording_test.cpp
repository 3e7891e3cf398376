// Recordings are untrusted: every defect measured against the old reader (printf-format scan
// patterns, unchecked counts and rates, short ground truth, silently ignored CAN stamps) is a test
// here expecting a clear error naming the field, on a small hand-built recording.
#include "firmware/protocol/can_message_types.hpp"
#include "host_sim/cloud_io/pcd.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "recording_dir_test.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <unistd.h>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

Json pose(double z) { return Json::array({0.0, 0.0, z, 0.0, 0.0, 0.0, 1.0}); }

// Two frames, one infra map cloud, a CAN log: everything RecordingReader::open reads.
class HostileRecording : public test::RecordingDirTest {
 protected:
  void SetUp() override {
    make_recording("hostile", 2);
    fs::create_directories(dir_ / "ego_lidar");
    fs::create_directories(dir_ / "infra");
    cloud_io::PointCloud cloud;
    cloud.points = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}};
    cloud.width = 3;
    cloud.height = 1;
    std::string err;
    for (const char* f : {"ego_lidar/000000.pcd", "ego_lidar/000001.pcd", "infra/000000.pcd"})
      ASSERT_TRUE(cloud_io::write_pcd((dir_ / f).string(), cloud, cloud_io::PcdEncoding::kBinary, err)) << err;
    write("ground_truth.tum", "# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n0.1 1 0 0 0 0 0 1\n");
    write("ground_truth_100hz.tum", "0 0 0 0 0 0 0 1\n0.01 0.1 0 0 0 0 0 1\n0.02 0.2 0 0 0 0 0 1\n");
    write("can.log", "(1700000000.050000) can0 120#0000000000000000\n(1700000000.100000) can0 18FF0001#01\n");
    m_["files"]["can_log"] = "can.log";
    m_["can_log"] = {{"layout_version", protocol::kCanLayoutVersion}};
    m_["sensors"] = Json::array({{{"name", "ego_lidar"}, {"carrier", "ego"}, {"mount_in_body", pose(1.9)}},
                                 {{"name", "infra_0"}, {"carrier", "infrastructure"}, {"surveyed_pose_enu", pose(5)}}});
    m_["map_clouds"]["clouds"] = Json::array({{{"sensor", "infra_0"},
                                               {"kind", "infra"},
                                               {"stamp_s", 0.0},
                                               {"file", "infra/000000.pcd"},
                                               {"points", 3},
                                               {"sensor_pose_enu", pose(5)},
                                               {"true_sensor_pose_enu", pose(5)}}});
  }

  // Writes the manifest (or raw text) and returns open()'s error, "" when it opened.
  std::string open_error(const std::string& raw = "") {
    write("manifest.json", raw.empty() ? m_.dump(2) : raw);
    std::string err;
    return reader_.open(dir_.string(), err) ? std::string() : err;
  }
  void expect_refused(const std::string& what) {
    const std::string err = open_error();
    EXPECT_NE(err.find(what), std::string::npos) << "error: '" << err << "' manifest: " << m_.dump();
  }

  RecordingReader reader_;
};

TEST_F(HostileRecording, TheValidRecordingOpensAndReads) {
  ASSERT_EQ(open_error(), "");
  EXPECT_EQ(reader_.frame_count(), 2);
  EXPECT_DOUBLE_EQ(reader_.ego_lidar_mount().translation().z(), 1.9);
  ASSERT_EQ(reader_.infra_surveyed_poses().size(), 1u);
  cloud_io::PointCloud c;
  std::string err;
  ASSERT_TRUE(reader_.ego_scan(1, c, err)) << err;
  EXPECT_EQ(c.points.size(), 3u);
  ASSERT_TRUE(reader_.load_map_cloud(reader_.map_clouds().at(0), c, err)) << err;
  std::vector<CanLogFrame> can;
  ASSERT_TRUE(reader_.can_frames(can, err)) << err;
  ASSERT_EQ(can.size(), 2u);
  EXPECT_NEAR(can[0].t, 0.05, 1e-6);  // unix seconds as a double: 2.4e-7 s resolution near 1.7e9
  EXPECT_EQ(can[1].id, 0x18FF0001u | 0x80000000u);
  EXPECT_EQ(can[1].dlc, 1);
}

TEST_F(HostileRecording, ScanPatternIsDataNotAPrintfFormat) {
  // The old reader passed these to snprintf: "%s%s..." crashed, "%p" leaked a pointer.
  for (const char* p : {"%s%s%s%s%s%s%s%s.pcd", "%p", "%n%06d", "%06d%06d", "ego_lidar/%6d.pcd", "%0d", "000000.pcd",
                        "ego_lidar/%06x.pcd", "%06"}) {
    m_["files"]["ego_scan_pattern"] = p;
    expect_refused("files.ego_scan_pattern: want exactly one %0Nd");
  }
  m_["files"]["ego_scan_pattern"] = "ego_lidar/%06d.pcd";
  m_["files"]["disparity_pattern"] = "%s";
  expect_refused("files.disparity_pattern");
}

TEST_F(HostileRecording, FilePathsStayInsideTheRecording) {
  m_["files"]["ego_scan_pattern"] = "../../%06d.pcd";
  expect_refused("'..' leaves the recording");
  m_["files"]["ego_scan_pattern"] = "/etc/%06d";
  expect_refused("absolute path");
  m_["files"]["ego_scan_pattern"] = std::string("ego_lidar/\n%06d.pcd");
  expect_refused("control character");
  m_["files"]["ego_scan_pattern"] = "ego_lidar/%06d.pcd";
  m_["files"]["ground_truth"] = "../ground_truth.tum";
  expect_refused("files.ground_truth");
  m_["files"]["ground_truth"] = "ground_truth.tum";
  m_["map_clouds"]["clouds"][0]["file"] = "infra/../../x.pcd";
  expect_refused("map_clouds.clouds[0].file");
  m_["map_clouds"]["clouds"][0]["file"] = "infra/000000.pcd";
  m_["files"]["can_log"] = "/dev/zero";
  expect_refused("files.can_log");
}

TEST_F(HostileRecording, SymlinkOutOfTheRecordingIsRefused) {
  const fs::path outside = dir_.parent_path() / ("outside_" + std::to_string(::getpid()));
  fs::create_directories(outside);
  fs::copy_file(dir_ / "ego_lidar/000000.pcd", outside / "000000.pcd", fs::copy_options::overwrite_existing);
  fs::remove_all(dir_ / "ego_lidar");
  fs::create_directory_symlink(outside, dir_ / "ego_lidar");
  ASSERT_EQ(open_error(), "");
  cloud_io::PointCloud c;
  std::string err;
  EXPECT_FALSE(reader_.ego_scan(0, c, err));
  EXPECT_NE(err.find("resolves outside the recording"), std::string::npos) << err;
  fs::remove_all(outside);
}

// Only the current format is read: an older recording (format 1 has no format_version; a CAN
// layout 1 log no can_log.layout_version) or a newer one is refused by name, with the command
// that makes it again.
TEST_F(HostileRecording, OnlyTheCurrentFormatIsReadOthersAreToldHowToRegenerate) {
  ASSERT_EQ(open_error(), "");
  m_.erase("format_version");
  expect_refused("format_version: missing (a format-1 recording); this build reads only what it writes");
  expect_refused("v2xloc-sim generate");
  for (const Json& v : {Json(1), Json(0), Json(3), Json("2"), Json(2.5), Json(nullptr)}) {
    m_["format_version"] = v;
    expect_refused("format_version: " + v.dump() + ", not 2; this build reads only what it writes");
  }
  m_["format_version"] = 2;
  m_["can_log"].erase("layout_version");
  expect_refused("can_log.layout_version: missing (a CAN layout 1 log)");
  for (const Json& v : {Json(1), Json(3), Json("2")}) {
    m_["can_log"]["layout_version"] = v;
    expect_refused("can_log.layout_version: " + v.dump() + ", not 2; this build reads only what it writes");
  }
  m_["can_log"]["layout_version"] = 2;
  m_["files"].erase("trust_list");
  expect_refused("files.trust_list: missing");
  m_["files"]["trust_list"] = "trust_list.txt";
  ASSERT_EQ(open_error(), "");
}

// Quantised .pcdz clouds read through the same reader as float32 PCD; a damaged one is refused.
TEST_F(HostileRecording, QuantisedCloudsReadADamagedOneIsRefused) {
  cloud_io::PointCloud cloud;
  cloud.points = {{1.0f, 2.0f, 3.0f}, {-4.0f, 5.5f, 6.25f}};
  cloud.intensity = {0.5f, 1.0f};
  cloud.time = {0.0f, 0.0999f};
  std::string err;
  for (const char* f : {"ego_lidar/000000.pcdz", "ego_lidar/000001.pcdz", "infra/000000.pcdz"})
    ASSERT_TRUE(cloud_io::write_quantised_pcd((dir_ / f).string(), cloud, cloud_io::Quantisation{}, err)) << err;
  m_["files"]["ego_scan_pattern"] = "ego_lidar/%06d.pcdz";
  m_["map_clouds"]["clouds"][0]["file"] = "infra/000000.pcdz";
  ASSERT_EQ(open_error(), "");
  cloud_io::PointCloud c;
  ASSERT_TRUE(reader_.ego_scan(1, c, err)) << err;
  ASSERT_EQ(c.size(), 2u);
  EXPECT_NEAR(c.points[1].z(), 6.25f, 5e-4f);
  EXPECT_NEAR(c.time[1], 0.0999f, 1e-9f);
  ASSERT_TRUE(reader_.load_map_cloud(reader_.map_clouds().at(0), c, err)) << err;
  // A damaged quantised cloud is refused with the file's name, not read as garbage.
  std::string bytes;
  {
    std::ifstream in(dir_ / "ego_lidar/000000.pcdz", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  bytes[bytes.size() - 3] = static_cast<char>(bytes[bytes.size() - 3] ^ 0x5a);
  write("ego_lidar/000000.pcdz", bytes);
  EXPECT_FALSE(reader_.ego_scan(0, c, err));
  EXPECT_NE(err.find("000000.pcdz"), std::string::npos) << err;
  EXPECT_TRUE(c.empty());
}

TEST_F(HostileRecording, FrameCountMustBeAnIntegerInRange) {
  // -5 and 1e12 threw std::length_error (SIGABRT); a string gave 0 frames and exit code 0.
  for (const Json& v : {Json(-5), Json(0), Json(1e12), Json(5.5), Json("2"), Json(nullptr), Json(1000000000000LL),
                        Json(18446744073709551615ULL)}) {
    m_["frame_count"] = v;
    expect_refused("frame_count");
  }
  m_.erase("frame_count");
  expect_refused("frame_count: missing");
}

TEST_F(HostileRecording, NonFiniteNumbersAreNotJson) {
  std::string text = m_.dump(2);
  const std::string key = "\"frame_count\": 2";
  ASSERT_NE(text.find(key), std::string::npos);
  for (const char* bad : {"inf", "nan", "-Infinity", "1e999"}) {
    std::string t = text;
    t.replace(t.find(key), key.size(), std::string("\"frame_count\": ") + bad);
    const std::string err = open_error(t);
    EXPECT_FALSE(err.empty()) << bad;
    // 1e999 parses to inf in nlohmann-json: refused as out of range rather than as bad syntax.
    EXPECT_TRUE(err.find("not valid JSON") != std::string::npos || err.find("frame_count") != std::string::npos)
        << bad << ": " << err;
  }
  EXPECT_NE(open_error("{\"format\": \"v2xloc-recording\", ").find("not valid JSON"), std::string::npos);
  EXPECT_NE(open_error("[1, 2]").find("format: missing"), std::string::npos);
}

TEST_F(HostileRecording, FrameRateMustBePositive) {
  for (const Json& v : {Json(0.0), Json(-10.0), Json("10"), Json(1e9)}) {
    m_["frame_rate_hz"] = v;
    expect_refused("frame_rate_hz");
  }
}

TEST_F(HostileRecording, TimeOriginAndGeodeticOriginAreCheckedNumbers) {
  m_["time_origin_unix_s"] = "1700000000";
  expect_refused("time_origin_unix_s");
  m_["time_origin_unix_s"] = 1700000000.0;
  m_["geodetic_origin"]["lat_deg"] = 91.0;
  expect_refused("geodetic_origin.lat_deg");
}

TEST_F(HostileRecording, PosesNeedSevenFiniteNumbersAndAUnitQuaternion) {
  m_["sensors"][0]["mount_in_body"] = Json::array({0.0, 0.0, 1.9, 0.0, 0.0, 0.0});  // 6 numbers: ignored before
  expect_refused("sensors[0].mount_in_body");
  m_["sensors"][0]["mount_in_body"] = Json::array({0.0, 0.0, 1.9, 0.0, 0.0, 0.0, 2.0});
  expect_refused("sensors[0].mount_in_body");
  m_["sensors"][0]["mount_in_body"] = Json::array({0.0, 0.0, "1.9", 0.0, 0.0, 0.0, 1.0});
  expect_refused("sensors[0].mount_in_body");
  m_["sensors"][0]["mount_in_body"] = pose(1.9);
  m_["sensors"][1]["surveyed_pose_enu"] = "here";
  expect_refused("sensors[1].surveyed_pose_enu");
  m_["sensors"][1]["surveyed_pose_enu"] = pose(5);
  m_["map_clouds"]["clouds"][0]["sensor_pose_enu"] = pose(5);
  m_["map_clouds"]["clouds"][0]["kind"] = "satellite";
  expect_refused("map_clouds.clouds[0].kind");
  m_["map_clouds"]["clouds"][0]["kind"] = "infra";
  m_["map_clouds"]["clouds"][0]["points"] = -1;
  expect_refused("map_clouds.clouds[0].points");
  m_["sensors"].erase(0);
  expect_refused("sensors: no ego_lidar entry");
}

TEST_F(HostileRecording, GroundTruthMustCoverEveryFrame) {
  // Shorter than frame_count: 2,076 valgrind errors in the evaluator; empty: SIGSEGV.
  write("ground_truth.tum", "0 0 0 0 0 0 0 1\n");
  expect_refused("1 poses for frame_count 2");
  write("ground_truth.tum", "");
  expect_refused("0 poses for frame_count 2");
  write("ground_truth.tum", "0 0 0 0 0 0 0 1\n0.1 inf 0 0 0 0 0 1\n");
  expect_refused("line 2: non-finite value");
  write("ground_truth.tum", "0 0 0 0 0 0 0 1\n0 1 0 0 0 0 0 1\n");
  expect_refused("line 2: time stamps must increase");
  write("ground_truth.tum", "0 0 0 0 0 0 0 1 9\n0.1 1 0 0 0 0 0 1\n");
  expect_refused("line 1: want 8 numbers");
  write("ground_truth.tum", "0 0 0 0 0 0 0 1\n0.1 1 0 0 0 0 0 1\n");
  write("ground_truth_100hz.tum", "# nothing\n");
  expect_refused("ground_truth_100hz.tum: no poses");
}

TEST_F(HostileRecording, CandumpStampsAreStrict) {
  // "(inf)" parsed as a number: every CAN frame lay after the end and was silently ignored.
  for (const char* line : {"(inf) can0 120#00", "(nan) can0 120#00", "(1e9) can0 120#00", "(1700000000.5) can0 120#00",
                           "(-1.000000) can0 120#00", "(1700000000.000000) can0 120#0", "(1700000000.000000) can0 800#00",
                           "(17000000700000000.000000) can0 120#00"}) {  // seconds * 1e6 overflowed int64 (UBSan)
    write("can.log", std::string("(1700000000.000000) can0 120#00\n") + line + "\n");
    ASSERT_EQ(open_error(), "");
    std::vector<CanLogFrame> can;
    std::string err;
    EXPECT_FALSE(reader_.can_frames(can, err)) << line;
    EXPECT_NE(err.find("can.log line 2: "), std::string::npos) << line << ": " << err;
  }
}

}  // namespace
}  // namespace v2xloc::sim
