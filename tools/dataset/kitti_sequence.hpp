// KITTI odometry benchmark sequence folders (Geiger et al., "Are we ready for autonomous driving?
// The KITTI vision benchmark suite", CVPR 2012; the odometry devkit's readme describes the files):
//   SEQ_DIR/velodyne/NNNNNN.bin   scans, float32 x y z reflectance (sensor frame)
//   SEQ_DIR/times.txt             one timestamp [s] per scan
//   SEQ_DIR/calib.txt             "P0: ..." .. "P3: ..." (3x4) and "Tr: ..." (3x4, velodyne ->
//                                 left grey camera cam0: p_cam = Tr p_velo)
//   poses (optional)              one 3x4 row-major matrix per line (12 numbers): the pose of cam0
//                                 at scan k in cam0's frame at scan 0. Looked up as
//                                 SEQ_DIR/poses.txt, then as in the official download
//                                 (dataset/sequences/NN/ and dataset/poses/NN.txt).
#pragma once

#include "v2xloc/algo/core/types.hpp"

#include <optional>
#include <string>
#include <vector>

namespace v2xloc::dataset {

struct KittiSequence {
  std::string dir;
  std::string name;                    // folder name ("00")
  std::vector<std::string> scans;      // velodyne/*.bin, sorted
  std::vector<double> times;
  Mat4d velo_to_cam = Mat4d::Identity();  // Tr
  std::string poses_path;              // empty: no ground truth
  std::vector<Mat4d> poses;            // ground truth, cam0 frame (empty without)
};

// False with a message naming the file and line on anything missing or malformed.
bool load_kitti_sequence(const std::string& dir, const std::optional<std::string>& poses_override,
                         KittiSequence& out, std::string& error);

bool read_kitti_calib_tr(const std::string& path, Mat4d& tr, std::string& error);
bool read_kitti_times(const std::string& path, std::vector<double>& times, std::string& error);
bool read_kitti_poses(const std::string& path, std::vector<Mat4d>& poses, std::string& error);
bool write_kitti_poses(const std::string& path, const std::vector<Mat4d>& poses, std::string& error);

// Pose of the velodyne (odometry frame = velodyne at scan 0) -> KITTI's cam0 convention:
// T_cam = Tr T_velo Tr^-1.
Mat4d velo_pose_to_cam(const Mat4d& velo_pose, const Mat4d& tr);

}  // namespace v2xloc::dataset
