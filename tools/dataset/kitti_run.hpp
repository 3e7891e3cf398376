// v2xloc-dataset kitti: the project's LiDAR odometry (algo/localization/odometry) over a KITTI
// sequence, poses written in KITTI's format (cam0 frame), KITTI metrics when ground truth exists.
#pragma once

#include "tools/dataset/kitti_metrics.hpp"
#include "tools/dataset/kitti_sequence.hpp"
#include "v2xloc/algo/localization/odometry.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace v2xloc::dataset {

struct KittiRunOptions {
  std::string seq_dir;
  std::optional<std::string> poses_path;  // ground truth override
  std::optional<std::string> out_path;    // estimated poses (KITTI format)
  OdometryParams odometry{};              // KISS-ICP's KITTI settings: voxel 1 m, range 100 m
};

struct KittiRunResult {
  KittiSequence sequence;
  std::vector<Mat4d> poses;               // estimate, cam0 frame, one per scan
  std::vector<OdometryStatus> status;     // per scan
  std::size_t points_read = 0;
  double odometry_ms = 0.0;               // thread CPU, whole sequence
  double read_ms = 0.0;
  std::optional<KittiMetrics> metrics;    // when ground truth exists
};

// False with a message on unreadable/malformed input (the folder, a scan, the output path).
bool run_kitti(const KittiRunOptions& options, KittiRunResult& result, std::string& error);

nlohmann::ordered_json kitti_json(const KittiRunOptions& options, const KittiRunResult& result);
std::string kitti_table(const KittiRunOptions& options, const KittiRunResult& result);

}  // namespace v2xloc::dataset
