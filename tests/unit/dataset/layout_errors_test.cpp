// Malformed KITTI / DAIR-V2X-C folders give one clear message naming the problem, never a crash.
#include "tools/dataset/dair_v2x.hpp"
#include "tools/dataset/kitti_sequence.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace v2xloc::dataset {
namespace {

namespace fs = std::filesystem;

class DatasetLayout : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("v2xloc_layout_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void write(const std::string& rel, const std::string& text) {
    fs::create_directories((dir_ / rel).parent_path());
    std::ofstream(dir_ / rel, std::ios::binary) << text;
  }
  std::string root() const { return dir_.string(); }
  // A valid one-scan KITTI sequence.
  void kitti_ok() {
    write("velodyne/000000.bin", std::string(32, '\0'));
    write("times.txt", "0.0\n");
    write("calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n");
  }
  fs::path dir_;
};

TEST_F(DatasetLayout, KittiValidSequenceLoads) {
  kitti_ok();
  write("poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  KittiSequence seq;
  std::string error;
  ASSERT_TRUE(load_kitti_sequence(root(), std::nullopt, seq, error)) << error;
  EXPECT_EQ(seq.scans.size(), 1u);
  EXPECT_EQ(seq.poses.size(), 1u);
  EXPECT_DOUBLE_EQ(seq.velo_to_cam(2, 0), 1.0);
}

TEST_F(DatasetLayout, KittiErrorsNameTheProblem) {
  KittiSequence seq;
  std::string error;
  EXPECT_FALSE(load_kitti_sequence(root() + "/nope", std::nullopt, seq, error));
  EXPECT_NE(error.find("not a directory"), std::string::npos) << error;
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("velodyne/"), std::string::npos) << error;

  kitti_ok();
  write("times.txt", "0.0\n0.1\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("2 timestamps for 1 scans"), std::string::npos) << error;

  kitti_ok();
  write("calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("no 'Tr:' line"), std::string::npos) << error;
  write("calib.txt", "Tr: 1 2 3\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("calib.txt:1: 'Tr:' needs 12 numbers"), std::string::npos) << error;
  write("calib.txt", "Tr: 2 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("not a rotation"), std::string::npos) << error;

  kitti_ok();
  write("poses.txt", "1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("poses.txt:1: expected 12 numbers"), std::string::npos) << error;
  write("poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("2 poses for 1 scans"), std::string::npos) << error;
  write("times.txt", "abc\n");
  EXPECT_FALSE(load_kitti_sequence(root(), std::nullopt, seq, error));
  EXPECT_NE(error.find("times.txt:1: expected one number"), std::string::npos) << error;
}

// The official download keeps ground truth apart: dataset/poses/NN.txt next to dataset/sequences/NN.
TEST_F(DatasetLayout, KittiFindsOfficialPosesFolder) {
  const std::string seq_dir = root() + "/dataset/sequences/07";
  write("dataset/sequences/07/velodyne/000000.bin", std::string(16, '\0'));
  write("dataset/sequences/07/times.txt", "0\n");
  write("dataset/sequences/07/calib.txt", "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  write("dataset/poses/07.txt", "1 0 0 5 0 1 0 0 0 0 1 0\n");
  KittiSequence seq;
  std::string error;
  ASSERT_TRUE(load_kitti_sequence(seq_dir, std::nullopt, seq, error)) << error;
  ASSERT_EQ(seq.poses.size(), 1u);
  EXPECT_DOUBLE_EQ(seq.poses[0](0, 3), 5.0);
}

TEST_F(DatasetLayout, DairErrorsNameTheProblem) {
  std::vector<DairPair> pairs;
  std::size_t missing = 0;
  std::string error;
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("no cooperative/data_info.json"), std::string::npos) << error;
  write("cooperative/data_info.json", "[{\"vehicle_pointcloud_path\": ");
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("not valid JSON"), std::string::npos) << error;
  write("cooperative/data_info.json", "{\"a\": 1}");
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("expected a JSON array"), std::string::npos) << error;
  write("cooperative/data_info.json", "[{\"vehicle_pointcloud_path\": 3}]");
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("entry 0: needs string fields"), std::string::npos) << error;
  write("cooperative/data_info.json",
        "[{\"vehicle_pointcloud_path\": \"vehicle-side/velodyne/000001.pcd\", "
        "\"infrastructure_pointcloud_path\": \"infrastructure-side/velodyne/000002.pcd\", "
        "\"system_error_offset\": {\"delta_x\": \"x\"}}]");
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("system_error_offset needs numbers"), std::string::npos) << error;
  write("cooperative/data_info.json",
        "[{\"vehicle_pointcloud_path\": \"vehicle-side/velodyne/000001.pcd\", "
        "\"infrastructure_pointcloud_path\": \"infrastructure-side/velodyne/000002.pcd\"}]");
  EXPECT_FALSE(read_dair_pairs(root(), pairs, missing, error));
  EXPECT_NE(error.find("none of the 1 pairs"), std::string::npos) << error;
  // Present clouds: the pair is listed, its id is the file stem.
  write("vehicle-side/velodyne/000001.pcd", "x");
  write("infrastructure-side/velodyne/000002.pcd", "x");
  ASSERT_TRUE(read_dair_pairs(root(), pairs, missing, error)) << error;
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].vehicle_id, "000001");
  EXPECT_EQ(pairs[0].infrastructure_id, "000002");
  EXPECT_EQ(pairs[0].calib_path, root() + "/cooperative/calib/lidar_i2v/000001.json");
  EXPECT_FALSE(pairs[0].has_offset);
}

TEST_F(DatasetLayout, LidarI2vFormats) {
  Mat4d t;
  std::string error;
  write("a.json", "{\"rotation\": [[0,-1,0],[1,0,0],[0,0,1]], \"translation\": [[1.5],[-2],[0.25]]}");
  ASSERT_TRUE(read_lidar_i2v(root() + "/a.json", t, error)) << error;
  EXPECT_DOUBLE_EQ(t(1, 0), 1.0);
  EXPECT_DOUBLE_EQ(t(1, 3), -2.0);
  write("b.json", "{\"transform\": {\"rotation\": [[1,0,0],[0,1,0],[0,0,1]], \"translation\": [1, 2, 3]}}");
  ASSERT_TRUE(read_lidar_i2v(root() + "/b.json", t, error)) << error;
  EXPECT_DOUBLE_EQ(t(2, 3), 3.0);
  write("c.json", "{\"rotation\": [[1,0],[0,1,0],[0,0,1]], \"translation\": [[1],[2],[3]]}");
  EXPECT_FALSE(read_lidar_i2v(root() + "/c.json", t, error));
  EXPECT_NE(error.find("3 rows of 3 numbers"), std::string::npos) << error;
  write("d.json", "{\"rotation\": [[2,0,0],[0,1,0],[0,0,1]], \"translation\": [[1],[2],[3]]}");
  EXPECT_FALSE(read_lidar_i2v(root() + "/d.json", t, error));
  EXPECT_NE(error.find("not a rotation"), std::string::npos) << error;
  EXPECT_FALSE(read_lidar_i2v(root() + "/missing.json", t, error));
  EXPECT_NE(error.find("cannot open"), std::string::npos) << error;
}

}  // namespace
}  // namespace v2xloc::dataset
