// Read access to a recording folder (host_sim/RECORDING_FORMAT.md): frames with the ego scan
// (per-point time), ground truth, disparity maps + stereo calibration, the infrastructure/agent
// map clouds with their reported poses, and the CAN log.
// A recording is untrusted input: open() checks every manifest field it uses (type, range,
// finiteness), file names are data (one `%0Nd` frame-index token, paths that stay inside the
// folder), the ground truth must cover every frame; any violation is an error naming the field.
// Only the current format is read (format_version 2, CAN layout 2): an older recording is refused
// with the command that makes it again.
#pragma once

#include "hal/emulated/hid_script.hpp"
#include "host_sim/canlog/candump_log.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"

#include <Eigen/Geometry>
#include <cstdint>
#include <fstream>
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

// Largest manifest the reader accepts; ours are ~100 kB even with 1000s of map clouds.
inline constexpr std::size_t kMaxManifestBytes = 64u << 20;

class RecordingReader {
 public:
  // The manifest format_version written and read: quantised .pcdz clouds, a trust list, CAN
  // layout 2 (protocol::kCanLayoutVersion, firmware/protocol/can_message_types.hpp).
  static constexpr int kFormatVersion = 2;

  bool open(const std::string& dir, std::string& error);

  // Upper bound on frame_count: 24 h at 10 Hz, far beyond any recording, bounds the allocations.
  static constexpr int kMaxFrames = 864'000;

  const std::string& dir() const { return dir_; }
  int scenario() const { return scenario_; }
  const std::string& permutation() const { return permutation_; }
  int frame_count() const { return frame_count_; }
  double frame_rate() const { return frame_rate_; }
  // Stamp of frame i [s]: manifest frame_stamps_s when given (a real sensor's stamps jitter),
  // otherwise i / frame_rate_hz.
  double frame_time(int i) const {
    return frame_stamps_.empty() ? i / frame_rate_ : frame_stamps_[static_cast<std::size_t>(i)];
  }
  double time_origin_unix() const { return time_origin_unix_; }
  double origin_lat_deg() const { return origin_lat_deg_; }
  double origin_lon_deg() const { return origin_lon_deg_; }
  double origin_alt_m() const { return origin_alt_m_; }
  // The simulator's world seed and sensor set-up (the world of a survey: sim_background.hpp);
  // 1 and false when the manifest does not say.
  std::uint64_t seed() const { return seed_; }
  bool quick() const { return quick_; }

  // Ego LiDAR scan of frame i: sensor frame, per-point time relative to frame_time(i).
  bool ego_scan(int i, cloud_io::PointCloud& out, std::string& error) const;
  const Eigen::Isometry3d& ego_lidar_mount() const { return ego_lidar_mount_; }  // sensor -> body

  // GNSS antenna in the body frame (manifest gnss.antenna_in_body); false when the manifest does not say.
  bool gnss_antenna_in_body(Eigen::Vector3d& out) const {
    if (!has_gnss_antenna_) return false;
    out = gnss_antenna_;
    return true;
  }

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
  const std::vector<Eigen::Isometry3d>& infra_surveyed_poses() const { return infra_poses_; }
  const std::vector<std::string>& infra_sensor_names() const { return infra_names_; }  // same order

  // CAN log (candump -L format: "(unix.usec) iface ID#DATA", host_sim/canlog). False if the
  // recording has none or any line is malformed.
  std::string can_log_path() const;
  // trust_list.txt of the recording (manifest files.trust_list).
  std::string trust_list_path() const;
  bool can_frames(std::vector<CanLogFrame>& out, std::string& error) const;
  // The same log as candump records (unix time stamps).
  bool can_records(std::vector<CandumpRecord>& out, std::string& error) const;

  // The ego IMU's HID input reports (manifest files.imu_reports, optional; hal/HID_IMU_REPORT.md),
  // one per line "<receive time ns of recording time> <hex bytes>" (hal/emulated/hid_script.hpp):
  // empty path when the recording has none. imu_reports() fails on a malformed line or times
  // going backwards.
  std::string imu_reports_path() const;
  bool imu_reports(std::vector<hal::HidScriptLine>& out, std::string& error) const;

  // A per-frame file name: literal text around one `%0Nd` token (N = 1..9), e.g. "ego_lidar/%06d.pcd".
  struct IndexPattern {
    std::string prefix, suffix;
    int width = 0;  // 0: no pattern
    std::string format(int index) const;
  };
  static bool parse_index_pattern(const std::string& text, IndexPattern& out, std::string& error);

  // The manifest's checks alone, on its text (no file access): the first step of open(), and
  // what the manifest fuzz target drives.
  bool parse_manifest(const std::string& text, std::string& error);

 private:
  // dir_/rel, provided rel is a plain relative path whose real location is inside the recording.
  bool resolve(const std::string& rel, std::string& path, std::string& error) const;
  // A file the manifest lists (empty name: "recording has no <what>"), resolved and opened.
  bool open_listed(const std::string& file, const char* what, std::ifstream& in, std::string& path,
                   std::string& error) const;
  // The steps of parse_manifest, each over the parsed manifest; false + error naming the field.
  bool read_timing_and_origin(const Json& m, std::string& error);
  bool read_files(const Json& m, std::string& error);
  bool read_sensors(const Json& m, std::string& error);
  bool read_stereo_calibration(const Json& entry, const std::string& where, std::string& error);
  bool read_map_clouds(const Json& m, std::string& error);

  std::string dir_, real_dir_;
  int scenario_ = 0;
  std::string permutation_;
  int frame_count_ = 0;
  double frame_rate_ = 10.0;
  std::vector<double> frame_stamps_;
  bool has_gnss_antenna_ = false;
  Eigen::Vector3d gnss_antenna_ = Eigen::Vector3d::Zero();
  double time_origin_unix_ = 0;
  double origin_lat_deg_ = 0, origin_lon_deg_ = 0, origin_alt_m_ = 0;
  std::uint64_t seed_ = 1;
  bool quick_ = false;
  IndexPattern scan_pattern_, disparity_pattern_;
  std::string gt_file_, gt100_file_, can_log_file_, trust_list_file_, imu_reports_file_;
  std::vector<Eigen::Isometry3d> infra_poses_;
  std::vector<std::string> infra_names_;
  Eigen::Isometry3d ego_lidar_mount_ = Eigen::Isometry3d::Identity();
  std::vector<TimedPose> gt_, gt100_;
  bool has_stereo_ = false;
  StereoCalibrationInfo stereo_;
  std::vector<MapCloudInfo> map_clouds_;
};

}  // namespace v2xloc::sim
