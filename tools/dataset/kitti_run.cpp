#include "tools/dataset/kitti_run.hpp"

#include "host_sim/cloud_io/kitti_bin.hpp"
#include "tools/dataset/dataset_common.hpp"

#include <chrono>
#include <cstdio>

namespace v2xloc::dataset {
namespace {

// The odometry and its raw-sweep scratch (~24 MB): static storage, as on the ECU.
struct RawSweepOdometry {
  LidarOdometry odometry;
  OdometryScanBuffers buffers;
};

RawSweepOdometry& raw_sweep_odometry() {
  static RawSweepOdometry state;
  return state;
}

double wall_ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

const char* status_name(OdometryStatus s) {
  switch (s) {
    case OdometryStatus::kOk: return "ok";
    case OdometryStatus::kFirstFrame: return "first_frame";
    case OdometryStatus::kEmptyScan: return "empty_scan";
    case OdometryStatus::kNoCorrespondences: return "no_correspondences";
    case OdometryStatus::kDegenerate: return "degenerate";
  }
  return "unknown";
}

}  // namespace

bool run_kitti(const KittiRunOptions& options, KittiRunResult& result, std::string& error) {
  result = KittiRunResult{};
  if (!load_kitti_sequence(options.seq_dir, options.poses_path, result.sequence, error)) return false;
  RawSweepOdometry& state = raw_sweep_odometry();
  LidarOdometry& odom = state.odometry;
  odom.configure(options.odometry);
  odom.reset();
  cloud_io::PointCloud cloud;
  for (const std::string& scan : result.sequence.scans) {
    const auto t0 = std::chrono::steady_clock::now();
    if (!cloud_io::read_kitti_bin(scan, cloud, error)) return false;
    result.read_ms += wall_ms_since(t0);
    result.points_read += cloud.size();
    const std::uint64_t c0 = thread_cpu_ns();
    const OdometryResult r = odom.register_frame(cloud.points, state.buffers);
    result.odometry_ms += static_cast<double>(thread_cpu_ns() - c0) * 1e-6;
    result.status.push_back(r.status);
    result.poses.push_back(velo_pose_to_cam(r.pose.matrix(), result.sequence.velo_to_cam));
  }
  if (!result.sequence.poses.empty())
    result.metrics = kitti_odometry_metrics(result.sequence.poses, result.poses);
  if (options.out_path && !write_kitti_poses(*options.out_path, result.poses, error)) return false;
  return true;
}

nlohmann::ordered_json kitti_json(const KittiRunOptions& options, const KittiRunResult& result) {
  nlohmann::ordered_json j;
  j["sequence"] = result.sequence.dir;
  j["scans"] = result.sequence.scans.size();
  j["points"] = result.points_read;
  std::size_t counts[5] = {};
  for (OdometryStatus s : result.status) ++counts[static_cast<int>(s)];
  nlohmann::ordered_json status;
  for (int i = 0; i < 5; ++i) status[status_name(static_cast<OdometryStatus>(i))] = counts[i];
  j["odometry_status"] = status;
  j["voxel_m"] = options.odometry.voxel_size;
  j["ms_per_scan"] = result.status.empty() ? 0.0 : result.odometry_ms / static_cast<double>(result.status.size());
  j["read_ms_per_scan"] = result.status.empty() ? 0.0 : result.read_ms / static_cast<double>(result.status.size());
  j["poses_out"] = options.out_path ? nlohmann::ordered_json(*options.out_path) : nlohmann::ordered_json();
  if (result.metrics) {
    const KittiMetrics& m = *result.metrics;
    nlohmann::ordered_json mj;
    mj["ground_truth"] = result.sequence.poses_path;
    mj["length_set"] = m.length_set;
    mj["step_frames"] = m.step;
    mj["path_length_m"] = m.path_length_m;
    mj["segments"] = m.segments;
    mj["translation_error_pct"] = m.translation_pct;
    mj["rotation_error_deg_per_100m"] = m.rotation_deg_per_100m;
    nlohmann::ordered_json lengths = nlohmann::ordered_json::array();
    for (const KittiLengthError& l : m.per_length) {
      lengths.push_back({{"length_m", l.length_m},
                         {"segments", l.segments},
                         {"translation_error_pct", l.translation_pct},
                         {"rotation_error_deg_per_100m", l.rotation_deg_per_100m}});
    }
    mj["per_length"] = lengths;
    j["metrics"] = mj;
  } else {
    j["metrics"] = nullptr;
  }
  return j;
}

std::string kitti_table(const KittiRunOptions& options, const KittiRunResult& result) {
  std::string out;
  char line[256];
  std::snprintf(line, sizeof(line), "sequence %s: %zu scans, %.1f ms/scan odometry (voxel %.2f m)\n",
                result.sequence.dir.c_str(), result.sequence.scans.size(),
                result.status.empty() ? 0.0 : result.odometry_ms / static_cast<double>(result.status.size()),
                options.odometry.voxel_size);
  out += line;
  if (options.out_path) out += "poses written to " + *options.out_path + " (KITTI format, camera 0 frame)\n";
  if (!result.metrics) {
    out += "no ground-truth poses: metrics not computed\n";
    return out;
  }
  const KittiMetrics& m = *result.metrics;
  std::snprintf(line, sizeof(line),
                "KITTI metrics over %zu segments (%s lengths, start every %d frames; path %.1f m)\n",
                m.segments, m.length_set == "kitti" ? "100..800 m" : "10..80 % of the path", m.step,
                m.path_length_m);
  out += line;
  out += "  length [m]  segments  t_err [%]  r_err [deg/100m]\n";
  for (const KittiLengthError& l : m.per_length) {
    std::snprintf(line, sizeof(line), "  %10.1f  %8zu  %9.3f  %16.4f\n", l.length_m, l.segments,
                  l.translation_pct, l.rotation_deg_per_100m);
    out += line;
  }
  std::snprintf(line, sizeof(line), "  %10s  %8zu  %9.3f  %16.4f\n", "all", m.segments, m.translation_pct,
                m.rotation_deg_per_100m);
  out += line;
  return out;
}

}  // namespace v2xloc::dataset
