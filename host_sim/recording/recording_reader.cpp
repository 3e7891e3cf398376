#include "host_sim/recording/recording_reader.hpp"

#include "host_sim/cloud_io/pcd.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace v2xloc::sim {
namespace {

std::string format_index(const std::string& pattern, int i) {
  char buf[512];
  std::snprintf(buf, sizeof buf, pattern.c_str(), i);
  return buf;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

bool RecordingReader::open(const std::string& dir, std::string& error) {
  dir_ = dir;
  if (!read_json_file(dir + "/manifest.json", manifest_, error)) return false;
  if (manifest_["format"].as_string() != "v2xloc-recording") {
    error = "not a v2xloc recording: " + dir;
    return false;
  }
  frame_count_ = manifest_["frame_count"].as_int();
  frame_rate_ = manifest_["frame_rate_hz"].as_number(10.0);
  const Json& files = manifest_["files"];
  scan_pattern_ = files["ego_scan_pattern"].as_string();
  disparity_pattern_ = files["disparity_pattern"].as_string();
  if (scan_pattern_.find("%06d") == std::string::npos) {
    error = "manifest: bad ego_scan_pattern";
    return false;
  }
  if (!read_tum(dir + "/" + files["ground_truth"].as_string(), gt_, error)) return false;
  if (!read_tum(dir + "/" + files["ground_truth_100hz"].as_string(), gt100_, error)) return false;
  for (const Json& s : manifest_["sensors"].items()) {
    const std::string name = s["name"].as_string();
    if (name == "ego_lidar") pose_from_json(s["mount_in_body"], ego_lidar_mount_);
    if (name == "ego_stereo") {
      has_stereo_ = disparity_pattern_.find("%06d") != std::string::npos;
      stereo_.width = s["width"].as_int();
      stereo_.height = s["height"].as_int();
      stereo_.fx = s["fx"].as_number();
      stereo_.fy = s["fy"].as_number();
      stereo_.cx = s["cx"].as_number();
      stereo_.cy = s["cy"].as_number();
      stereo_.baseline = s["baseline_m"].as_number();
      stereo_.disparity_sigma_px = s["disparity_sigma_px"].as_number();
      pose_from_json(s["camera_to_body"], stereo_.camera_to_body);
    }
  }
  map_clouds_.clear();
  for (const Json& c : manifest_["map_clouds"]["clouds"].items()) {
    MapCloudInfo m;
    m.sensor = c["sensor"].as_string();
    m.kind = c["kind"].as_string();
    m.stamp = c["stamp_s"].as_number();
    m.file = c["file"].as_string();
    m.points = static_cast<std::size_t>(c["points"].as_number());
    if (!pose_from_json(c["sensor_pose_enu"], m.sensor_pose) || !pose_from_json(c["true_sensor_pose_enu"], m.true_sensor_pose)) {
      error = "manifest: bad map cloud pose for " + m.file;
      return false;
    }
    map_clouds_.push_back(std::move(m));
  }
  std::stable_sort(map_clouds_.begin(), map_clouds_.end(),
                   [](const MapCloudInfo& a, const MapCloudInfo& b) { return a.stamp < b.stamp; });
  return true;
}

bool RecordingReader::ego_scan(int i, cloud_io::PointCloud& out, std::string& error) const {
  if (i < 0 || i >= frame_count_) {
    error = "frame index out of range";
    return false;
  }
  return cloud_io::read_pcd(dir_ + "/" + format_index(scan_pattern_, i), out, error);
}

Eigen::Isometry3d RecordingReader::ground_truth_at(double t) const {
  if (gt100_.empty()) return Eigen::Isometry3d::Identity();
  if (t <= gt100_.front().t) return gt100_.front().pose;
  if (t >= gt100_.back().t) return gt100_.back().pose;
  const auto it = std::upper_bound(gt100_.begin(), gt100_.end(), t, [](double v, const TimedPose& p) { return v < p.t; });
  const TimedPose& b = *it;
  const TimedPose& a = *(it - 1);
  const double s = (t - a.t) / (b.t - a.t);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.translation() = (1 - s) * a.pose.translation() + s * b.pose.translation();
  out.linear() = Eigen::Quaterniond(a.pose.linear()).slerp(s, Eigen::Quaterniond(b.pose.linear())).toRotationMatrix();
  return out;
}

bool RecordingReader::disparity(int i, Image16& out, std::string& error) const {
  if (!has_stereo_) {
    error = "recording has no stereo";
    return false;
  }
  if (i < 0 || i >= frame_count_) {
    error = "frame index out of range";
    return false;
  }
  return read_png16(dir_ + "/" + format_index(disparity_pattern_, i), out, error);
}

std::vector<const MapCloudInfo*> RecordingReader::map_clouds_until(double t) const {
  std::vector<const MapCloudInfo*> out;
  for (const auto& m : map_clouds_)
    if (m.stamp <= t + 1e-9) out.push_back(&m);
  return out;
}

std::vector<const MapCloudInfo*> RecordingReader::latest_map_clouds(double t) const {
  std::vector<const MapCloudInfo*> out;
  for (const auto& m : map_clouds_) {
    if (m.stamp > t + 1e-9) break;
    auto it = std::find_if(out.begin(), out.end(), [&](const MapCloudInfo* o) { return o->sensor == m.sensor; });
    if (it == out.end()) out.push_back(&m);
    else *it = &m;
  }
  return out;
}

bool RecordingReader::load_map_cloud(const MapCloudInfo& info, cloud_io::PointCloud& out, std::string& error) const {
  return cloud_io::read_pcd(dir_ + "/" + info.file, out, error);
}

std::vector<Eigen::Isometry3d> RecordingReader::infra_surveyed_poses() const {
  std::vector<Eigen::Isometry3d> out;
  for (const Json& s : manifest_["sensors"].items()) {
    if (s["carrier"].as_string() != "infrastructure") continue;
    Eigen::Isometry3d p;
    if (pose_from_json(s["surveyed_pose_enu"], p)) out.push_back(p);
  }
  return out;
}

std::string RecordingReader::trust_list_path() const {
  const std::string f = manifest_["files"]["trust_list"].as_string();
  return f.empty() ? std::string() : dir_ + "/" + f;
}

std::string RecordingReader::can_log_path() const {
  const std::string f = manifest_["files"]["can_log"].as_string();
  return f.empty() ? std::string() : dir_ + "/" + f;
}

bool parse_candump_line(const std::string& line, double& unix_time, CanLogFrame& out) {
  // "(1700000000.123456) can0 123#DEADBEEF"
  if (line.size() < 10 || line[0] != '(') return false;
  const auto close = line.find(')');
  if (close == std::string::npos) return false;
  auto res = std::from_chars(line.data() + 1, line.data() + close, unix_time);
  if (res.ec != std::errc()) return false;
  std::size_t p = close + 1;
  while (p < line.size() && line[p] == ' ') ++p;
  const auto sp = line.find(' ', p);
  if (sp == std::string::npos) return false;
  out.interface = line.substr(p, sp - p);
  const std::string frame = line.substr(sp + 1);
  const auto hash = frame.find('#');
  if (hash == std::string::npos || hash == 0 || hash > 8) return false;
  std::uint32_t id = 0;
  for (std::size_t k = 0; k < hash; ++k) {
    const int d = hex_digit(frame[k]);
    if (d < 0) return false;
    id = (id << 4) | static_cast<std::uint32_t>(d);
  }
  if (hash == 8) id |= 0x80000000u;  // 29-bit identifiers are written with 8 hex digits
  out.id = id;
  std::size_t q = hash + 1;
  out.dlc = 0;
  while (q < frame.size() && hex_digit(frame[q]) >= 0) {
    if (q + 1 >= frame.size() || hex_digit(frame[q + 1]) < 0 || out.dlc >= 8) return false;
    out.data[out.dlc++] = static_cast<std::uint8_t>(hex_digit(frame[q]) * 16 + hex_digit(frame[q + 1]));
    q += 2;
  }
  return true;
}

bool RecordingReader::can_frames(std::vector<CanLogFrame>& out, std::string& error) const {
  out.clear();
  const std::string path = can_log_path();
  if (path.empty()) {
    error = "recording has no CAN log";
    return false;
  }
  std::ifstream in(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  const double t0 = time_origin_unix();
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    CanLogFrame f;
    double unix_time = 0;
    if (!parse_candump_line(line, unix_time, f)) {
      error = "bad candump line: " + line;
      return false;
    }
    f.t = unix_time - t0;
    out.push_back(f);
  }
  return true;
}

}  // namespace v2xloc::sim
