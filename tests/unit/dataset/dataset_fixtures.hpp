// Writes small folders in the KITTI odometry and DAIR-V2X-C layouts from the simulated
// intersection (real dataset files cannot be committed). Generated at test time into a temp
// folder: a few seconds, and the repository stays small.
#pragma once

#include "v2xloc/algo/core/types.hpp"

#include <string>
#include <vector>

namespace v2xloc::testing {

struct KittiFixtureInfo {
  std::vector<Mat4d> cam_poses;   // ground truth written to poses.txt (cam0 frame)
  double path_length_m = 0.0;
};

// SEQ_DIR/{velodyne/NNNNNN.bin, times.txt, calib.txt, poses.txt}: `frames` sweeps at 10 Hz of a
// 32-beam LiDAR on a car driving north and turning left at the intersection (~8 m/s).
bool write_kitti_fixture(const std::string& seq_dir, int frames, KittiFixtureInfo& info, std::string& error);

struct DairFixtureInfo {
  std::vector<std::string> vehicle_ids;   // pairs written (clouds present)
  std::vector<Mat4d> truth;               // p_vehicle = T p_infrastructure, per pair
  std::vector<Vec3d> offsets;             // system_error_offset (dx, dy, 0) per pair
};

// ROOT/{cooperative/data_info.json, cooperative/calib/lidar_i2v/<vid>.json,
// vehicle-side/velodyne/<vid>.pcd, infrastructure-side/velodyne/<iid>.pcd}: `pairs` (<= 3)
// vehicle / corner-unit pairs at the intersection plus one data_info entry whose clouds are
// absent. The written lidar_i2v is the truth minus the pair's offset (the offset corrects it).
bool write_dair_fixture(const std::string& root, int pairs, DairFixtureInfo& info, std::string& error);

}  // namespace v2xloc::testing
