// Read access to a recording folder (host_sim/RECORDING_FORMAT.md): frames with the ego scan
// (per-point time), ground truth, disparity maps + stereo calibration, the infrastructure/agent
// map clouds with their reported poses, and the CAN log.
#pragma once

#include "host_sim/common/json.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace v2xloc::sim {

struct StereoCalibrationInfo {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0, baseline = 0;
  Eigen::Isometry3d camera_to_body = Eigen::Isometry3d::Identity();
  double disparity_sigma_px = 0;
};

struct MapCloudInfo {
  std::string sensor;     // infra_0.., agent_0_lidar..
  std::string kind;       // "infra" | "agent"
  double stamp = 0;       // s
  std::string file;       // relative to the recording folder
  std::size_t points = 0;
  Eigen::Isometry3d sensor_pose = Eigen::Isometry3d::Identity();       // reported, sensor -> ENU
  Eigen::Isometry3d true_sensor_pose = Eigen::Isometry3d::Identity();  // truth, sensor -> ENU
};

struct CanLogFrame {
  double t = 0;           // recording time (unix time - time_origin_unix_s)
  std::string interface;  // e.g. can0
  std::uint32_t id = 0;   // with bit 31 set for 29-bit ids (as hal::CanFrame)
  std::uint8_t dlc = 0;
  std::uint8_t data[8] = {};
};

class RecordingReader {
 public:
  bool open(const std::string& dir, std::string& error);

  const std::string& dir() const { return dir_; }
  const Json& manifest() const { return manifest_; }
  int scenario() const { return manifest_["scenario"]["id"].as_int(); }
  std::string permutation() const { return manifest_["permutation"].as_string(); }
  int frame_count() const { return frame_count_; }
  double frame_rate() const { return frame_rate_; }
  double frame_time(int i) const { return i / frame_rate_; }
  double time_origin_unix() const { return manifest_["time_origin_unix_s"].as_number(); }
  double origin_lat_deg() const { return manifest_["geodetic_origin"]["lat_deg"].as_number(); }
  double origin_lon_deg() const { return manifest_["geodetic_origin"]["lon_deg"].as_number(); }
  double origin_alt_m() const { return manifest_["geodetic_origin"]["alt_m"].as_number(); }

  // Ego LiDAR scan of frame i: sensor frame, per-point time relative to frame_time(i).
  bool ego_scan(int i, cloud_io::PointCloud& out, std::string& error) const;
  const Eigen::Isometry3d& ego_lidar_mount() const { return ego_lidar_mount_; }  // sensor -> body

  // Ground truth ego body pose (body -> ENU) at the frame stamps and at 100 Hz.
  const std::vector<TimedPose>& ground_truth() const { return gt_; }
  const std::vector<TimedPose>& ground_truth_100hz() const { return gt100_; }
  // Body pose at any time in the recording (interpolated from the 100 Hz truth).
  Eigen::Isometry3d ground_truth_at(double t) const;

  // Disparity map of frame i (uint16, d = value / 256, 0 invalid) and its calibration.
  bool has_stereo() const { return has_stereo_; }
  bool disparity(int i, Image16& out, std::string& error) const;
  const StereoCalibrationInfo& stereo_calibration() const { return stereo_; }

  // Map clouds sorted by stamp; those with stamp <= t; loading one.
  const std::vector<MapCloudInfo>& map_clouds() const { return map_clouds_; }
  std::vector<const MapCloudInfo*> map_clouds_until(double t) const;
  // The newest cloud of every sensor with stamp <= t (the current reference map inputs).
  std::vector<const MapCloudInfo*> latest_map_clouds(double t) const;
  bool load_map_cloud(const MapCloudInfo& info, cloud_io::PointCloud& out, std::string& error) const;
  std::vector<Eigen::Isometry3d> infra_surveyed_poses() const;

  // CAN log (candump -L format: "(unix.usec) iface ID#DATA"). False if the recording has none.
  std::string can_log_path() const;
  // trust_list.txt of the recording (manifest files.trust_list); empty for recordings made before it.
  std::string trust_list_path() const;
  bool can_frames(std::vector<CanLogFrame>& out, std::string& error) const;

 private:
  std::string dir_;
  Json manifest_;
  int frame_count_ = 0;
  double frame_rate_ = 10.0;
  std::string scan_pattern_, disparity_pattern_;
  Eigen::Isometry3d ego_lidar_mount_ = Eigen::Isometry3d::Identity();
  std::vector<TimedPose> gt_, gt100_;
  bool has_stereo_ = false;
  StereoCalibrationInfo stereo_;
  std::vector<MapCloudInfo> map_clouds_;
};

// Parses one candump -L line; false for malformed lines.
bool parse_candump_line(const std::string& line, double& unix_time, CanLogFrame& out);

}  // namespace v2xloc::sim
