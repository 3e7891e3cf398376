// A scratch recording folder per test (under the build tree, removed afterwards) and the smallest
// manifest RecordingReader::open accepts: one frame, an ego LiDAR, ground truth, no map clouds.
// Tests add the files and manifest keys they are about.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <unistd.h>

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/pose_io.hpp"

namespace v2xloc::sim::test {

class RecordingDirTest : public ::testing::Test {
 protected:
  // Creates BINARY_DIR/test_tmp/<group>/<test>_<pid> with a one-frame ground truth (10 Hz and
  // 100 Hz) and puts the manifest for `frames` frames in m_ (not written yet; a test with more
  // frames writes its own ground truth).
  void make_recording(const std::string& group, int frames = 1) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::path(V2XLOC_BINARY_DIR) / "test_tmp" / group /
           (std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    write("ground_truth.tum", "0 0 0 0 0 0 0 1\n");
    write("ground_truth_100hz.tum", "0 0 0 0 0 0 0 1\n0.01 0.1 0 0 0 0 0 1\n");
    m_ = {{"format", "v2xloc-recording"},
          {"format_version", 2},
          {"scenario", {{"id", 0}}},
          {"permutation", "2_infra"},
          {"frame_rate_hz", 10.0},
          {"frame_count", frames},
          {"time_origin_unix_s", 1700000000.0},
          {"geodetic_origin", {{"lat_deg", 48.1}, {"lon_deg", 11.5}, {"alt_m", 520.0}}},
          {"files",
           {{"ego_scan_pattern", "ego_lidar/%06d.pcd"},
            {"ground_truth", "ground_truth.tum"},
            {"ground_truth_100hz", "ground_truth_100hz.tum"},
            {"trust_list", "trust_list.txt"}}},
          {"sensors", Json::array({{{"name", "ego_lidar"}, {"mount_in_body", Json::array({0, 0, 1.9, 0, 0, 0, 1})}}})},
          {"map_clouds", {{"clouds", Json::array()}}}};
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  void write(const std::string& rel, const std::string& text) {
    std::string err;
    ASSERT_TRUE(write_text_file((dir_ / rel).string(), text, err)) << err;
  }
  std::string read(const std::string& rel) {
    std::string text, err;
    EXPECT_TRUE(read_text_file((dir_ / rel).string(), 1u << 20, text, err)) << err;
    return text;
  }

  std::filesystem::path dir_;
  Json m_;
};

}  // namespace v2xloc::sim::test
