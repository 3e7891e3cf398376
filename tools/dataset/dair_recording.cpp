#include "tools/dataset/dair_recording.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "host_sim/cloud_io/pcd.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/gnss/gnss_simulator.hpp"
#include "host_sim/recording/can_log_writer.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_background.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/vehicle/vehicle_signals.hpp"
#include "host_sim/world/intersection_world.hpp"
#include "tools/dataset/dair_calib.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::dataset {
namespace {

namespace fs = std::filesystem;
using InJson = nlohmann::json;
using sim::Json;
using Iso = Eigen::Isometry3d;

constexpr const char* kRoadsideSensor = "infra_0";
constexpr double kFramePeriodS = 0.1;            // both LiDARs sweep at 10 Hz
constexpr double kInnerLaneM = 1.75;            // the simulated street's inner lane, right of its axis
constexpr double kBackgroundVoxelM = 0.25;       // static-cell test of the roadside sweeps
// Noise streams (derive_seed keys), apart from the simulator's recorder streams.
enum Stream : std::uint64_t { kGnssStream = 16, kVehicleStream = 17 };

struct VehicleFrame {
  std::string id, pcd;
  std::int64_t stamp_us = 0;
  Iso world_T_lidar = Iso::Identity();
  Iso novatel_T_lidar = Iso::Identity();  // the LiDAR in the NovAtel (GNSS antenna) frame
};

struct RoadsideFrame {
  std::string id, pcd;
  std::int64_t stamp_us = 0;
  Iso world_T_sensor = Iso::Identity();
};

// A string field of a cooperative/data_info.json entry ("" when absent or not a string).
std::string text_of(const InJson& e, const char* key) {
  return e.is_object() && e.contains(key) && e[key].is_string() ? e[key].get<std::string>() : std::string();
}

// Released rotations are orthonormal to ~1e-7, not exactly: projected onto SO(3) so that every
// pose written (and the unit quaternion a survey or a share declares) is one rotation.
Iso projected(const Mat4d& m) {
  Iso out = Iso::Identity();
  out.linear() = Eigen::Quaterniond(Eigen::Matrix3d(m.topLeftCorner<3, 3>())).normalized().toRotationMatrix();
  out.translation() = m.topRightCorner<3, 1>();
  return out;
}

bool stamp_known(const DairFrame& f, const char* side, std::string& error) {
  if (f.timestamp_us > 0) return true;
  error = std::string(side) + "/data_info.json frame " + f.id + ": pointcloud_timestamp missing or not microseconds";
  return false;
}

// The scans of one vehicle-side sequence (batch_id) whose clouds are present, by time stamp.
bool read_vehicle_frames(const DairCalib& calib, const std::string& batch, std::vector<VehicleFrame>& frames,
                         std::string& chosen_batch, std::string& error) {
  std::map<std::string, int> batches;
  for (const auto& [id, f] : calib.vehicle_frames()) ++batches[f.batch_id];
  chosen_batch = batch;
  if (chosen_batch.empty()) {
    if (batches.size() != 1) {
      error = "vehicle-side/data_info.json holds " + std::to_string(batches.size()) +
              " sequences (batch_id); pick one with --batch";
      return false;
    }
    chosen_batch = batches.begin()->first;
  } else if (!batches.count(chosen_batch)) {
    error = "vehicle-side/data_info.json has no batch_id '" + chosen_batch + "'";
    return false;
  }
  for (const auto& [id, d] : calib.vehicle_frames()) {
    if (d.batch_id != chosen_batch) continue;
    if (!stamp_known(d, "vehicle-side", error)) return false;
    if (!fs::is_regular_file(d.pointcloud_path)) continue;  // a folder may hold part of a sequence
    Mat4d world_T_novatel, novatel_T_lidar;
    if (!calib.vehicle_calibs(id, world_T_novatel, novatel_T_lidar, error)) return false;
    VehicleFrame f;
    f.id = id;
    f.pcd = d.pointcloud_path;
    f.stamp_us = d.timestamp_us;
    f.novatel_T_lidar = projected(novatel_T_lidar);
    f.world_T_lidar = projected(world_T_novatel) * f.novatel_T_lidar;
    frames.push_back(std::move(f));
  }
  std::sort(frames.begin(), frames.end(), [](const VehicleFrame& a, const VehicleFrame& b) { return a.stamp_us < b.stamp_us; });
  for (std::size_t i = 1; i < frames.size(); ++i) {
    if (frames[i].stamp_us <= frames[i - 1].stamp_us) {
      error = "vehicle frames " + frames[i - 1].id + " and " + frames[i].id + " share a time stamp";
      return false;
    }
  }
  if (frames.size() < 2) {
    error = "vehicle-side: sequence '" + chosen_batch + "' has fewer than two scans present";
    return false;
  }
  return true;
}

// The roadside unit of the sequence: the (intersection, batch) of the roadside frames that
// cooperative/data_info.json pairs with its vehicle frames; its system_error_offset (median).
struct RoadsideChoice {
  std::string intersection, batch;
  double delta_x = 0.0, delta_y = 0.0;
  int pairs = 0;
};

bool choose_roadside(const std::string& root, const DairCalib& calib, const std::vector<VehicleFrame>& vehicle,
                     RoadsideChoice& out, std::string& error) {
  InJson pairs;
  if (!read_dair_json(root + "/cooperative/data_info.json", pairs, error)) return false;
  if (!pairs.is_array()) {
    error = root + "/cooperative/data_info.json must be an array";
    return false;
  }
  std::map<std::string, int> units;
  std::vector<double> dx, dy;
  for (const InJson& p : pairs) {
    const std::string vid = fs::path(text_of(p, "vehicle_pointcloud_path")).stem().string();
    if (std::none_of(vehicle.begin(), vehicle.end(), [&](const VehicleFrame& f) { return f.id == vid; })) continue;
    const auto it = calib.roadside_frames().find(fs::path(text_of(p, "infrastructure_pointcloud_path")).stem().string());
    if (it == calib.roadside_frames().end()) continue;
    ++units[it->second.intersection + "\n" + it->second.batch_id];
    if (p.contains("system_error_offset") && p["system_error_offset"].is_object()) {
      const InJson& o = p["system_error_offset"];
      if (o.contains("delta_x") && o["delta_x"].is_number() && o.contains("delta_y") && o["delta_y"].is_number()) {
        dx.push_back(o["delta_x"].get<double>());
        dy.push_back(o["delta_y"].get<double>());
      }
    }
  }
  if (units.empty()) {
    error = root + "/cooperative/data_info.json pairs none of the sequence's vehicle scans with a roadside frame";
    return false;
  }
  const auto best = std::max_element(units.begin(), units.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  const std::size_t cut = best->first.find('\n');
  out.intersection = best->first.substr(0, cut);
  out.batch = best->first.substr(cut + 1);
  out.pairs = best->second;
  const auto median = [](std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  out.delta_x = median(dx);
  out.delta_y = median(dy);
  if (!std::isfinite(out.delta_x) || !std::isfinite(out.delta_y) || std::abs(out.delta_x) > 100 || std::abs(out.delta_y) > 100) {
    error = root + "/cooperative/data_info.json: system_error_offset not finite or beyond 100 m";
    return false;
  }
  return true;
}

// The unit's scans stamped within [first_us, last_us] whose clouds are present, by time stamp.
bool read_roadside_frames(const DairCalib& calib, const RoadsideChoice& unit, std::int64_t first_us,
                          std::int64_t last_us, std::vector<RoadsideFrame>& frames, std::string& error) {
  for (const auto& [id, d] : calib.roadside_frames()) {
    if (d.intersection != unit.intersection || d.batch_id != unit.batch) continue;
    if (!stamp_known(d, "infrastructure-side", error)) return false;
    if (d.timestamp_us < first_us || d.timestamp_us > last_us || !fs::is_regular_file(d.pointcloud_path)) continue;
    Mat4d world_T_sensor;
    if (!calib.world_from_roadside_lidar(id, world_T_sensor, error)) return false;
    frames.push_back({id, d.pointcloud_path, d.timestamp_us, projected(world_T_sensor)});
  }
  std::sort(frames.begin(), frames.end(), [](const RoadsideFrame& a, const RoadsideFrame& b) { return a.stamp_us < b.stamp_us; });
  if (frames.empty()) {
    error = "infrastructure-side: no roadside scan of " + unit.intersection + " during the drive";
    return false;
  }
  return true;
}

double yaw_of(const Iso& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

Iso interpolate(const std::vector<sim::TimedPose>& poses, double t) {
  if (!(t > poses.front().t)) return poses.front().pose;
  if (t >= poses.back().t) return poses.back().pose;
  const auto it = std::upper_bound(poses.begin(), poses.end(), t, [](double v, const sim::TimedPose& p) { return v < p.t; });
  const sim::TimedPose& b = *it;
  const sim::TimedPose& a = *(it - 1);
  const double s = (t - a.t) / (b.t - a.t);
  Iso out = Iso::Identity();
  out.translation() = (1 - s) * a.pose.translation() + s * b.pose.translation();
  out.linear() = Eigen::Quaterniond(a.pose.linear()).slerp(s, Eigen::Quaterniond(b.pose.linear())).toRotationMatrix();
  return out;
}

// LiDAR height above the road: the median over 1 m cells 3-15 m around the sensor of each cell's
// lowest return (most such cells hold road), negated.
double lidar_height(const cloud_io::PointCloud& scan) {
  std::map<std::pair<int, int>, float> lowest;
  for (const Eigen::Vector3f& p : scan.points) {
    const float r = p.head<2>().norm();
    if (!p.allFinite() || r < 3.0f || r > 15.0f) continue;
    const std::pair<int, int> key{static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y()))};
    const auto it = lowest.find(key);
    if (it == lowest.end() || p.z() < it->second) lowest[key] = p.z();
  }
  std::vector<float> z;
  for (const auto& kv : lowest) z.push_back(kv.second);
  if (z.empty()) return 0.0;
  std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2), z.end());
  return -static_cast<double>(z[z.size() / 2]);
}

// Speed along the body x axis and yaw rate at each ground-truth stamp (central differences).
struct Motion {
  double speed = 0.0, yaw_rate = 0.0;
};
std::vector<Motion> motion_of(const std::vector<sim::TimedPose>& gt) {
  std::vector<Motion> out(gt.size());
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(gt.size() - 1, i + 1);
    const double dt = gt[b].t - gt[a].t;
    const Eigen::Vector3d v = (gt[b].pose.translation() - gt[a].pose.translation()) / dt;
    out[i].speed = v.dot(gt[i].pose.linear().col(0));
    out[i].yaw_rate = std::remainder(yaw_of(gt[b].pose) - yaw_of(gt[a].pose), 2.0 * M_PI) / dt;
  }
  return out;
}

Motion motion_at(const std::vector<sim::TimedPose>& gt, const std::vector<Motion>& m, double t) {
  if (!(t > gt.front().t)) return m.front();
  if (t >= gt.back().t) return m.back();
  const std::size_t b = static_cast<std::size_t>(
      std::upper_bound(gt.begin(), gt.end(), t, [](double v, const sim::TimedPose& p) { return v < p.t; }) - gt.begin());
  const double s = (t - gt[b - 1].t) / (gt[b].t - gt[b - 1].t);
  return {(1 - s) * m[b - 1].speed + s * m[b].speed, (1 - s) * m[b - 1].yaw_rate + s * m[b].yaw_rate};
}

// The simulated canyon laid on the real intersection: recording frame -> simulator frame.
struct CanyonFrame {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double rotation = 0.0;  // recording yaw of the simulator's x axis
  Eigen::Vector3d to_sim(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d d = Eigen::Rotation2Dd(-rotation) * (p.head<2>() - centre);
    return {d.x(), d.y(), p.z()};
  }
  Eigen::Vector3d rotate_to_sim(const Eigen::Vector3d& v) const {
    const Eigen::Vector2d d = Eigen::Rotation2Dd(-rotation) * v.head<2>();
    return {d.x(), d.y(), v.z()};
  }
  Eigen::Vector3d rotate_from_sim(const Eigen::Vector3d& v) const {
    const Eigen::Vector2d d = Eigen::Rotation2Dd(rotation) * v.head<2>();
    return {d.x(), d.y(), v.z()};
  }
};

struct GnssResult {
  std::vector<sim::GnssFix> fixes;
  double mean_h_error = 0.0, max_h_error = 0.0;
  int valid = 0;
};

GnssResult simulate_gnss(const DairRecordingOptions& o, const std::vector<sim::TimedPose>& gt100,
                         const Eigen::Vector3d& antenna_in_body, const CanyonFrame& canyon,
                         const GeodeticOrigin& origin, double duration) {
  sim::IntersectionWorld iw;
  sim::WorldConfig wc;
  wc.seed = o.seed;  // the simulator's world of the same seed
  sim::build_intersection_world(wc, iw);
  iw.world.set_time(0.0);
  sim::GnssConfig config;
  config.epoch_offset_s = 3600.0 * o.gnss_epoch_hour;
  sim::GnssSimulator receiver(config, iw.world, origin, sim::derive_seed(o.seed, {kGnssStream}));
  GnssResult out;
  const int n = static_cast<int>(std::floor(duration * o.gnss_rate_hz + 1e-9)) + 1;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double t = k / o.gnss_rate_hz;
    constexpr double kHalfStep = 0.005;  // s
    const Eigen::Vector3d antenna = interpolate(gt100, t) * antenna_in_body;
    const Eigen::Vector3d velocity = (interpolate(gt100, t + kHalfStep) * antenna_in_body -
                                      interpolate(gt100, t - kHalfStep) * antenna_in_body) / (2.0 * kHalfStep);
    const Eigen::Vector3d antenna_sim = canyon.to_sim(antenna);
    sim::GnssFix fix = receiver.fix(t, antenna_sim, canyon.rotate_to_sim(velocity));
    // The simulated error, rotated back onto the real antenna.
    const Eigen::Vector3d estimate = antenna + canyon.rotate_from_sim(fix.enu_estimate - antenna_sim);
    const Eigen::Vector3d vel = canyon.rotate_from_sim({fix.vel_east, fix.vel_north, fix.vel_up});
    fix.enu_estimate = estimate;
    fix.vel_east = vel.x();
    fix.vel_north = vel.y();
    fix.vel_up = vel.z();
    const EcefToGeodeticResult g = ecef_to_geodetic(enu_to_ecef(origin, estimate));
    fix.lat_deg = g.point.lat_deg;
    fix.lon_deg = g.point.lon_deg;
    fix.alt_m = g.point.alt_m;
    if (fix.valid) {
      const double e = (estimate - antenna).head<2>().norm();
      sum += e;
      out.max_h_error = std::max(out.max_h_error, e);
      ++out.valid;
    }
    out.fixes.push_back(fix);
  }
  if (out.valid > 0) out.mean_h_error = sum / out.valid;
  return out;
}

// Roadside background: the points of the voxels hit in at least kBackgroundMinShare of the sweeps
// (what stands still), in the sensor frame.
std::vector<Eigen::Vector3f> static_points(const std::vector<cloud_io::PointCloud>& sweeps, double min_share) {
  struct Cell {
    int last_sweep = -1, sweeps = 0;
  };
  std::map<std::array<int, 3>, Cell> cells;
  const auto key = [](const Eigen::Vector3f& p) {
    return std::array<int, 3>{static_cast<int>(std::floor(p.x() / kBackgroundVoxelM)),
                              static_cast<int>(std::floor(p.y() / kBackgroundVoxelM)),
                              static_cast<int>(std::floor(p.z() / kBackgroundVoxelM))};
  };
  for (std::size_t s = 0; s < sweeps.size(); ++s) {
    for (const Eigen::Vector3f& p : sweeps[s].points) {
      if (!p.allFinite()) continue;
      Cell& c = cells[key(p)];
      if (c.last_sweep != static_cast<int>(s)) {
        c.last_sweep = static_cast<int>(s);
        ++c.sweeps;
      }
    }
  }
  const int need = std::max(1, static_cast<int>(std::ceil(min_share * static_cast<double>(sweeps.size()))));
  std::vector<Eigen::Vector3f> out;
  for (const cloud_io::PointCloud& sweep : sweeps)
    for (const Eigen::Vector3f& p : sweep.points)
      if (p.allFinite() && cells[key(p)].sweeps >= need) out.push_back(p);
  return out;
}

std::string frame_file(const std::string& dir, std::size_t index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "/%06zu.pcdz", index);
  return dir + buf;
}

// Intensity to [0, 1]: DAIR's vehicle LiDAR stores 0-255 as uint8, the roadside one as float
// in the same range.
void normalise_intensity(cloud_io::PointCloud& c) {
  for (float& v : c.intensity) v = std::isfinite(v) ? std::clamp(v / 255.0f, 0.0f, 1.0f) : 0.0f;
}

// ---- The steps of write_dair_recording, in order ----

// What the steps share: the options, the dataset's frames, the recording folder and what each
// step produces for the later ones.
struct Conversion {
  Conversion(const DairRecordingOptions& options, DairRecordingSummary& s) : o(options), summary(s), out(options.out_dir) {}
  const DairRecordingOptions& o;
  DairRecordingSummary& summary;
  const fs::path out;
  // The dataset: the vehicle sequence, the roadside unit paired with it and its scans.
  DairCalib calib;
  std::vector<VehicleFrame> vehicle;
  std::string batch;
  RoadsideChoice unit;
  std::vector<RoadsideFrame> roadside;
  std::int64_t t0_us = 0;  // the first vehicle scan's stamp: recording time 0
  // The recording frame and the roadside unit's pose in it.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  Iso roadside_pose = Iso::Identity();
  // Ego scans: the LiDAR mount, the ground truth at the scan stamps and at 100 Hz.
  Iso mount = Iso::Identity();
  std::vector<sim::TimedPose> gt, gt100;
  std::vector<double> stamps;
  // Roadside shares: their manifest entries and the sweeps (for the background).
  Json clouds = Json::array();
  std::vector<cloud_io::PointCloud> sweeps;
  // GNSS and the CAN log.
  Eigen::Vector3d antenna_in_body = Eigen::Vector3d::Zero();
  CanyonFrame canyon;
  GnssResult gnss;
  Json can_json;

  double seconds(std::int64_t us) const { return static_cast<double>(us - t0_us) * 1e-6; }
  Iso shifted(Iso T) const {
    T.translation() -= offset;
    return T;
  }
};

bool read_dataset(Conversion& c, std::string& error) {
  if (!c.calib.load(c.o.root, error) || !read_vehicle_frames(c.calib, c.o.batch, c.vehicle, c.batch, error) ||
      !choose_roadside(c.o.root, c.calib, c.vehicle, c.unit, error))
    return false;
  c.t0_us = c.vehicle.front().stamp_us;
  const std::int64_t end_us = c.vehicle.back().stamp_us + static_cast<std::int64_t>(kFramePeriodS * 1e6);
  return read_roadside_frames(c.calib, c.unit, c.t0_us, end_us, c.roadside, error);
}

bool create_folders(const Conversion& c, std::string& error) {
  std::error_code ec;
  fs::create_directories(c.out / "ego_lidar", ec);
  fs::create_directories(c.out / "infra" / kRoadsideSensor, ec);
  if (ec) {
    error = "cannot create " + c.o.out_dir + ": " + ec.message();
    return false;
  }
  return true;
}

// The roadside pose as DAIR-V2X's calib_i2v composes it (offset on the world translation); the
// recording frame's offset from it (whole metres) and the first scan's height.
void place_recording_frame(Conversion& c) {
  Iso roadside_world = c.roadside.front().world_T_sensor;
  if (c.o.system_error_offset) roadside_world.translation() += Eigen::Vector3d(c.unit.delta_x, c.unit.delta_y, 0.0);
  c.offset = roadside_world.translation().array().round();
  c.offset.z() = std::round(c.vehicle.front().world_T_lidar.translation().z());
  c.roadside_pose = c.shifted(roadside_world);
}

// The mount height from the first scan's road returns.
bool measure_mount(Conversion& c, const cloud_io::PointCloud& first_scan, const std::string& path, std::string& error) {
  c.summary.lidar_height_m = lidar_height(first_scan);
  if (!(c.summary.lidar_height_m > 0.5 && c.summary.lidar_height_m < 5.0)) {
    error = path + ": no road found below the LiDAR (height " + std::to_string(c.summary.lidar_height_m) + " m)";
    return false;
  }
  c.mount.translation() = Eigen::Vector3d(0.0, 0.0, c.summary.lidar_height_m);
  return true;
}

// Ego scans as recorded (point times clamped to the frame period), their stamps and the truth.
bool write_ego_scans(Conversion& c, std::string& error) {
  cloud_io::PointCloud scan;
  cloud_io::ReadOptions read;
  for (std::size_t i = 0; i < c.vehicle.size(); ++i) {
    read.time_offset_s = static_cast<double>(c.vehicle[i].stamp_us) * 1e-6;
    if (!cloud_io::read_pcd(c.vehicle[i].pcd, scan, error, read)) return false;
    if (scan.time.size() != scan.points.size()) {
      error = c.vehicle[i].pcd + ": no per-point timestamp field";
      return false;
    }
    if (i == 0 && !measure_mount(c, scan, c.vehicle[i].pcd, error)) return false;
    for (float& t : scan.time) {
      const float clamped = std::clamp(std::isfinite(t) ? t : 0.0f, 0.0f, static_cast<float>(kFramePeriodS) - 1e-6f);
      c.summary.times_clamped += clamped != t ? 1 : 0;
      t = clamped;
    }
    normalise_intensity(scan);
    scan.normals.clear();
    if (!cloud_io::write_quantised_pcd(frame_file((c.out / "ego_lidar").string(), i), scan, cloud_io::Quantisation{},
                                       error))
      return false;
    const double t = c.seconds(c.vehicle[i].stamp_us);
    c.stamps.push_back(t);
    c.gt.push_back({t, c.shifted(c.vehicle[i].world_T_lidar) * c.mount.inverse()});
  }
  c.summary.frames = static_cast<int>(c.vehicle.size());
  c.summary.duration_s = c.stamps.back() + kFramePeriodS;
  return true;
}

// Roadside clouds (the shares) with their manifest entries; the sweeps kept for the background.
bool write_roadside_clouds(Conversion& c, std::string& error) {
  for (std::size_t k = 0; k < c.roadside.size(); ++k) {
    cloud_io::PointCloud cloud;
    if (!cloud_io::read_pcd(c.roadside[k].pcd, cloud, error)) return false;
    normalise_intensity(cloud);
    cloud.time.clear();
    cloud.normals.clear();
    const std::string rel = frame_file(std::string("infra/") + kRoadsideSensor, k);
    if (!cloud_io::write_quantised_pcd((c.out / rel).string(), cloud, cloud_io::Quantisation{}, error)) return false;
    Json e = Json::object();
    e["sensor"] = kRoadsideSensor;
    e["kind"] = "infra";
    e["stamp_s"] = c.seconds(c.roadside[k].stamp_us);
    e["file"] = rel;
    e["points"] = cloud.points.size();
    e["sensor_pose_enu"] = sim::pose_to_json(c.roadside_pose);
    e["true_sensor_pose_enu"] = sim::pose_to_json(c.roadside_pose);
    e["dair_frame"] = c.roadside[k].id;
    c.clouds.push_back(std::move(e));
    c.sweeps.push_back(std::move(cloud));
  }
  c.summary.roadside_clouds = static_cast<int>(c.roadside.size());
  c.summary.first_roadside_s = c.seconds(c.roadside.front().stamp_us);
  return true;
}

// Ground truth at the scan stamps and at 100 Hz.
bool write_ground_truth(Conversion& c, std::string& error) {
  for (int k = 0; k * 0.01 <= c.stamps.back() + 1e-9; ++k) c.gt100.push_back({k * 0.01, interpolate(c.gt, k * 0.01)});
  return sim::write_tum((c.out / "ground_truth.tum").string(), c.gt, error) &&
         sim::write_tum((c.out / "ground_truth_100hz.tum").string(), c.gt100, error);
}

// GNSS through the simulated canyon, vehicle signals from the truth, both on the CAN log.
bool write_can_log(Conversion& c, std::string& error) {
  const DairRecordingOptions& o = c.o;
  const GeodeticOrigin origin = make_geodetic_origin(o.origin_lat_deg, o.origin_lon_deg, o.origin_alt_m);
  // The antenna (NovAtel reference point) in the body frame, from the first scan's calibration.
  c.antenna_in_body = c.mount * c.vehicle.front().novatel_T_lidar.inverse().translation();
  // The simulated street along the first heading, the drive starting in its inner lane
  // gnss_canyon_setback_m before the simulated intersection (as the simulator's Sim 0 ego).
  c.canyon.rotation = yaw_of(c.gt.front().pose);
  const Eigen::Vector2d forward(std::cos(c.canyon.rotation), std::sin(c.canyon.rotation)), left(-forward.y(), forward.x());
  c.canyon.centre = c.gt.front().pose.translation().head<2>() + o.gnss_canyon_setback_m * forward + kInnerLaneM * left;
  c.gnss = simulate_gnss(o, c.gt100, c.antenna_in_body, c.canyon, origin, c.stamps.back());
  c.summary.gnss_valid_fixes = c.gnss.valid;
  c.summary.gnss_mean_h_error_m = c.gnss.mean_h_error;
  c.summary.gnss_max_h_error_m = c.gnss.max_h_error;

  const std::vector<Motion> motion = motion_of(c.gt);
  sim::VehicleSignalSimulator signals(sim::VehicleSignalConfig{}, sim::derive_seed(o.seed, {kVehicleStream}));
  std::vector<sim::VehicleSignals> vehicle_signals;
  const int nv = static_cast<int>(std::floor(c.stamps.back() * o.vehicle_rate_hz + 1e-9)) + 1;
  for (int k = 0; k < nv; ++k) {
    const double t = k / o.vehicle_rate_hz;
    const Motion m = motion_at(c.gt, motion, t);
    vehicle_signals.push_back(signals.sample(t, m.speed, m.yaw_rate));
  }
  return sim::write_gnss_vehicle_can_log((c.out / "gnss_vehicle.log").string(), "gnss_vehicle.log",
                                         static_cast<double>(c.t0_us) * 1e-6, vehicle_signals, c.gnss.fixes, c.can_json,
                                         error);
}

// Trust list: the roadside unit's test key, survey and background.
bool write_trust_list(Conversion& c, std::string& error) {
  sim::SimSigner signer;
  if (!sim::sim_signer("infra", kRoadsideSensor, signer)) {
    error = "no test key for the roadside unit";
    return false;
  }
  signer.surveyed = true;
  signer.survey = sim::surveyed_pose(c.roadside_pose);
  trust::TrustList list = sim::trust_list_of({signer});
  sim::SimBackground background;
  if (!sim::background_from_points(static_points(c.sweeps, c.o.background_min_share), config::kBackgroundFileCells,
                                   background, error) ||
      !sim::write_background(c.o.out_dir, kRoadsideSensor, background, list.signers[0], error) ||
      !sim::write_text_file((c.out / sim::kTrustListFile).string(), sim::trust_list_text(list), error))
    return false;
  c.summary.background_cells = background.cells.size();
  return true;
}

// Where the recording comes from, its frames and units.
void describe_source(const Conversion& c, Json& m) {
  const DairRecordingOptions& o = c.o;
  m["source"] = Json{{"dataset", "DAIR-V2X-C"},
                     {"root", o.root},
                     {"vehicle_batch", c.batch},
                     {"roadside", c.unit.intersection + " batch " + c.unit.batch},
                     {"pairs_in_sequence", c.unit.pairs},
                     {"world_offset", std::vector<double>{c.offset.x(), c.offset.y(), c.offset.z()}},
                     {"world_offset_note", "recording frame = DAIR world frame - world_offset"},
                     {"system_error_offset_applied", o.system_error_offset},
                     {"system_error_offset", Json{{"delta_x", c.unit.delta_x}, {"delta_y", c.unit.delta_y}}},
                     {"ground_truth", "novatel_to_world * lidar_to_novatel * inverse(mount_in_body)"}};
  m["units"] = Json{{"frame", "DAIR world frame (local, x east, y north, z up) shifted by source.world_offset"},
                    {"body_frame", "vehicle LiDAR axes (x forward, y left, z up), origin on the road below it"},
                    {"time", "seconds since the first vehicle scan; unix time = time_origin_unix_s + t"},
                    {"pose", "[x, y, z, qx, qy, qz, qw], child frame in parent frame"},
                    {"intensity", "[0, 1]: the sensors' 0-255 / 255"}};
  m["files"] = Json{{"ego_scan_pattern", "ego_lidar/%06d.pcdz"},
                    {"ego_scan_fields", "x y z intensity t; sensor frame at each point's firing time; t = seconds since the frame stamp"},
                    {"frame_stamp", "frame_stamps_s"},
                    {"ground_truth", "ground_truth.tum"},
                    {"ground_truth_100hz", "ground_truth_100hz.tum"},
                    {"can_log", "gnss_vehicle.log"},
                    {"trust_list", sim::kTrustListFile}};
}

// The sensors, the map clouds, the GNSS model and the CAN log.
void describe_sensors(const Conversion& c, Json& m) {
  const DairRecordingOptions& o = c.o;
  Json ego = Json{{"name", "ego_lidar"}, {"carrier", "ego"}, {"type", "lidar"}, {"model", "Hesai Pandar40 (40 beams)"},
                  {"rate_hz", 1.0 / kFramePeriodS}, {"mount_in_body", sim::pose_to_json(c.mount)}};
  Json infra = Json{{"name", kRoadsideSensor}, {"carrier", "infrastructure"}, {"type", "lidar"},
                    {"rate_hz_published", 1.0 / kFramePeriodS}, {"surveyed_pose_enu", sim::pose_to_json(c.roadside_pose)},
                    {"background_note", "cells its own sweeps of the drive hit in at least half of them"}};
  m["sensors"] = Json::array({ego, infra});
  m["map_clouds"] = Json{{"fields", "x y z intensity (quantised), sensor frame (DAIR virtual LiDAR)"},
                         {"clouds", c.clouds}};
  const Eigen::Vector3d& a = c.antenna_in_body;
  m["gnss"] = Json{{"model", "host_sim/gnss urban-canyon receiver along the true antenna path, the simulated "
                             "intersection's buildings laid on this intersection"},
                   {"rate_hz", o.gnss_rate_hz},
                   {"epoch_offset_s", 3600.0 * o.gnss_epoch_hour},
                   {"antenna_in_body", std::vector<double>{a.x(), a.y(), a.z()}},
                   {"canyon_centre", std::vector<double>{c.canyon.centre.x(), c.canyon.centre.y()}},
                   {"canyon_setback_m", o.gnss_canyon_setback_m},
                   {"canyon_rotation_deg", c.canyon.rotation * 180.0 / M_PI},
                   {"valid_fixes", c.gnss.valid},
                   {"mean_horizontal_error_m", c.gnss.mean_h_error},
                   {"max_horizontal_error_m", c.gnss.max_h_error}};
  m["can_log"] = c.can_json;
}

bool write_manifest(const Conversion& c, std::string& error) {
  const DairRecordingOptions& o = c.o;
  Json m = Json::object();
  m["format"] = "v2xloc-recording";
  m["format_version"] = sim::RecordingReader::kFormatVersion;
  m["scenario"] = Json{{"id", 100},
                       {"name", "dair_v2x_c"},
                       {"description", "DAIR-V2X-C cooperative sequence (real data), intersection " + c.unit.intersection}};
  m["permutation"] = "real_1_infra";
  m["seed"] = static_cast<double>(o.seed);
  m["quick"] = false;
  m["duration_s"] = c.summary.duration_s;
  m["frame_rate_hz"] = 1.0 / kFramePeriodS;
  m["frame_count"] = c.summary.frames;
  m["frame_stamps_s"] = c.stamps;
  m["time_origin_unix_s"] = static_cast<double>(c.t0_us) * 1e-6;
  m["geodetic_origin"] = Json{{"lat_deg", o.origin_lat_deg}, {"lon_deg", o.origin_lon_deg}, {"alt_m", o.origin_alt_m},
                              {"note", "nominal: the release does not georeference its world frame"}};
  describe_source(c, m);
  describe_sensors(c, m);
  return sim::write_text_file((c.out / "manifest.json").string(), m.dump(2) + "\n", error);
}

}  // namespace

std::string DairRecordingSummary::one_line() const {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "%d scans over %.2f s, %d roadside clouds (first at %.2f s), LiDAR %.2f m above the road, GNSS "
                "%d fixes h-error mean %.2f m max %.2f m, background %zu cells, %zu point times clamped",
                frames, duration_s, roadside_clouds, first_roadside_s, lidar_height_m, gnss_valid_fixes,
                gnss_mean_h_error_m, gnss_max_h_error_m, background_cells, times_clamped);
  return buf;
}

bool write_dair_recording(const DairRecordingOptions& o, DairRecordingSummary& summary, std::string& error) {
  summary = DairRecordingSummary{};
  Conversion c(o, summary);
  if (!read_dataset(c, error) || !create_folders(c, error)) return false;
  place_recording_frame(c);
  return write_ego_scans(c, error) && write_roadside_clouds(c, error) && write_ground_truth(c, error) &&
         write_can_log(c, error) && write_trust_list(c, error) && write_manifest(c, error);
}

}  // namespace v2xloc::dataset
