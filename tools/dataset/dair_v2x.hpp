// v2xloc-dataset dair-v2x-c: global registration (algo/registration/register_clouds: FPFH +
// RANSAC + ICP, from no prior) of each infrastructure cloud to its vehicle cloud on DAIR-V2X-C
// cooperative folders (Yu et al., "DAIR-V2X: A Large-Scale Dataset for Vehicle-Infrastructure
// Cooperative 3D Object Detection", CVPR 2022), scored against the dataset's lidar_i2v calibration.
// Accepted layout (paths in data_info.json are relative to ROOT, as in the release):
//   ROOT/cooperative/data_info.json   array of {"vehicle_pointcloud_path":
//       "vehicle-side/velodyne/015344.pcd", "infrastructure_pointcloud_path":
//       "infrastructure-side/velodyne/000009.pcd", "system_error_offset": {"delta_x": dx,
//       "delta_y": dy}, optional "calib_lidar_i2v_path", other fields ignored}
//   ROOT/vehicle-side/velodyne/*.pcd, ROOT/infrastructure-side/velodyne/*.pcd
//   ROOT/cooperative/calib/lidar_i2v/<vehicle id>.json   {"rotation": 3x3 rows,
//       "translation": [[x],[y],[z]] (or [x,y,z])}, optionally wrapped in {"transform": {...}};
//       maps infrastructure-LiDAR points into the vehicle-LiDAR frame: p_v = R p_i + t
// system_error_offset: the calibration's known horizontal error; the corrected reference adds
// (delta_x, delta_y, 0) to the translation (as the DAIR-V2X tooling does).
// Entries whose point clouds are absent are skipped (counted): a folder may hold just some pairs.
#pragma once

#include "v2xloc/algo/registration/register_clouds.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace v2xloc::dataset {

struct DairPair {
  std::string vehicle_id, infrastructure_id;   // file stems ("015344")
  std::string vehicle_path, infrastructure_path, calib_path;  // absolute or ROOT-relative joined
  double delta_x = 0.0, delta_y = 0.0;         // system_error_offset (0 when absent)
  bool has_offset = false;
};

// Reads ROOT/cooperative/data_info.json. `pairs` holds the entries whose two clouds exist;
// `missing` counts the others. False with a message when the layout or the JSON is wrong.
bool read_dair_pairs(const std::string& root, std::vector<DairPair>& pairs, std::size_t& missing,
                     std::string& error);
// lidar_i2v JSON -> 4x4 (p_vehicle = T p_infrastructure).
bool read_lidar_i2v(const std::string& path, Mat4d& transform, std::string& error);

struct DairOptions {
  std::string root;
  // [m] register_clouds voxel. 1 m, not the core's 0.5 m default: on the simulated pairs 0.5 m
  // matched repeated structure (the intersection is nearly symmetric) on all three pairs, 1 m
  // registered all three within 1.1 cm / 0.015 deg; whole-scene pairs tens of metres apart
  // need coarse, distinctive features.
  float voxel = 1.0f;
  std::optional<std::uint64_t> seed;  // RANSAC seed
  std::size_t limit = 0;              // 0 = all pairs
  double success_translation_m = 1.0; // summary: a pair "succeeds" within these
  double success_rotation_deg = 2.0;
};

struct DairPairResult {
  DairPair pair;
  std::string status;      // "ok", registration failure name, or "error"
  std::string message;     // for "error"
  Mat4d estimate = Mat4d::Identity();
  Mat4d reference = Mat4d::Identity();
  double translation_error_m = 0.0, rotation_error_deg = 0.0;   // vs lidar_i2v as given
  double translation_error_corrected_m = 0.0;                   // vs lidar_i2v + offset
  double fitness = 0.0, inlier_rmse = 0.0;
  double ms = 0.0;          // register_clouds, thread CPU
  double read_ms = 0.0;
  std::size_t vehicle_points = 0, infrastructure_points = 0;
};

struct DairRunResult {
  std::vector<DairPairResult> pairs;
  std::size_t skipped_missing = 0;
};

// False only when the folder cannot be used at all; per-pair problems are per-pair statuses.
bool run_dair(const DairOptions& options, DairRunResult& result, std::string& error);

nlohmann::ordered_json dair_json(const DairOptions& options, const DairRunResult& result);
std::string dair_table(const DairOptions& options, const DairRunResult& result);

}  // namespace v2xloc::dataset
