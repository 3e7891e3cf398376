#include "host_sim/recording/recorder.hpp"

#include "host_sim/common/text_file.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_background.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/scenario/simulation.hpp"
#include "host_sim/sensors/lidar.hpp"
#include "host_sim/sensors/stereo.hpp"
#include "host_sim/cloud_io/pcd.hpp"

#include "host_sim/gnss/gnss_simulator.hpp"
#include "host_sim/recording/gnss_drive.hpp"
#include "host_sim/vehicle/vehicle_signals.hpp"
#include "host_sim/recording/can_log_writer.hpp"
#include "host_sim/recording/imu_reports.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

const cloud_io::Quantisation kCloudQuantisation{};
constexpr const char* kCloudFields =
    "x y z int32 x 0.001 m, intensity uint8 x 1/255, t uint32 x 1 ns (PCD header + SCALE, DATA binary_shuffled_zlib;"
    " v2xloc-sim export-pcd writes float32 PCD)";

// Stream ids for derive_seed (each sensor/frame gets its own noise stream).
enum Stream : std::uint64_t { kEgoLidar = 1, kStereo = 2, kInfra = 3, kAgentLidar = 4, kAgentPose = 5, kVehicle = 7 /* 6: GNSS, gnss_drive.cpp */, kImu = 8 };
constexpr const char* kImuReportsFile = "imu_reports.txt";

std::string frame_file(const char* dir, int index, const char* ext) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s/%06d.%s", dir, index, ext);
  return buf;
}

cloud_io::PointCloud to_cloud(const LidarScan& scan) {
  cloud_io::PointCloud c;
  c.points.reserve(scan.points.size());
  c.intensity.reserve(scan.points.size());
  c.time.reserve(scan.points.size());
  for (const auto& p : scan.points) {
    c.points.push_back(p.p);
    c.intensity.push_back(p.intensity);
    c.time.push_back(p.t);
  }
  c.width = static_cast<std::uint32_t>(c.points.size());
  c.height = 1;
  return c;
}

Json lidar_json(const LidarConfig& l) {
  Json j = Json::object();
  j["type"] = "lidar";
  j["beams"] = l.beams;
  j["elevation_max_deg"] = l.elevation_max_deg;
  j["elevation_min_deg"] = l.elevation_min_deg;
  j["azimuth_steps"] = l.azimuth_steps;
  j["azimuth_convention"] = "column c at -180 + 360 (c + 0.5) / azimuth_steps deg, counter-clockwise, 0 = +x";
  j["rate_hz"] = l.rate_hz;
  j["min_range_m"] = l.min_range;
  j["max_range_m"] = l.max_range;
  j["range_sigma_m"] = l.range_sigma;
  j["dropout"] = l.dropout;
  return j;
}

std::uint64_t folder_bytes(const fs::path& dir) {
  std::uint64_t total = 0;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file()) total += e.file_size();
  return total;
}

// ---- The steps of generate_recording, in order ----

// What every step shares: the configuration, the simulated scenario, the sensor set-up and where
// files go. Write errors are collected and reported after each step.
struct Session {
  explicit Session(const RecorderConfig& c) : cfg(c) {}
  const RecorderConfig& cfg;
  Simulation sim;
  fs::path root;
  LidarConfig ego_cfg;
  StereoConfig stereo_cfg;
  std::vector<InfraSite> sites;
  bool agents = false;
  int frames = 0;
  double dt_frame = 0.1;
  int map_every = 5;
  std::vector<std::string> errors;
  std::string err;  // scratch for the writers' messages
  // Scratch buffers reused by every frame.
  LidarScan scan;
  Image16 disparity;

  const Scenario& scenario() const { return sim.scenario; }
  World& world() { return sim.iw.world; }

  // Quantised (1 mm, intensity 1/255, 1 ns; pcd.hpp): the range noise (2 cm) is 20 steps, the
  // intensity noise (0.02) 5 steps, and a recording takes a quarter of float32 binary_compressed.
  void write_cloud(const std::string& rel, const LidarScan& s) {
    const cloud_io::PointCloud c = to_cloud(s);
    if (!cloud_io::write_quantised_pcd((root / rel).string(), c, kCloudQuantisation, err)) errors.push_back(err);
  }
  bool failed(std::string& error) const {
    if (errors.empty()) return false;
    error = errors.front();
    return true;
  }
};

// What the frame loop produces for the later steps.
struct FrameProducts {
  Json map_clouds = Json::array();
  std::vector<TimedPose> ground_truth;
  std::vector<double> points_per_scan;
};

// Agent self-localization error: a per-run bias (dx, dy, dyaw) drawn first, then per-cloud noise
// from the same stream, in cloud order (the stream order is part of the recording's bytes).
struct AgentPoseError {
  Rng rng;
  std::vector<Eigen::Vector3d> bias;
};

bool setup(Session& s, std::string& error) {
  const RecorderConfig& cfg = s.cfg;
  if (cfg.scenario < 0 || cfg.scenario >= kScenarioCount) {
    error = "scenario must be 0..3";
    return false;
  }
  const double duration = cfg.duration > 0 ? cfg.duration : (cfg.quick ? 3.0 : 0.0);
  WorldConfig world_config;
  world_config.terrain = cfg.terrain;
  build_simulation(cfg.scenario, cfg.seed, duration, world_config, s.sim);
  s.root = fs::path(cfg.out_dir);
  s.ego_cfg = ego_lidar_config(cfg.quick);
  s.stereo_cfg = ego_stereo_config(cfg.quick);
  s.sites = infra_sites(cfg.permutation, cfg.terrain);
  s.agents = uses_agents(cfg.permutation);
  s.frames = s.scenario().frame_count();
  s.dt_frame = 1.0 / s.scenario().frame_rate;
  s.map_every = std::max(1, static_cast<int>(std::lround(s.scenario().frame_rate / cfg.map_rate_hz)));
  return true;
}

bool create_folders(const Session& s, std::string& error) {
  std::error_code ec;
  fs::create_directories(s.root / "ego_lidar", ec);
  if (s.cfg.stereo) fs::create_directories(s.root / "stereo", ec);
  if (ec) {
    error = "cannot create " + s.root.string() + ": " + ec.message();
    return false;
  }
  for (const auto& site : s.sites) fs::create_directories(s.root / "infra" / site.name, ec);
  if (s.agents)
    for (std::size_t a = 0; a < s.scenario().agents.size(); ++a)
      fs::create_directories(s.root / "agents" / ("agent_" + std::to_string(a)), ec);
  return true;
}

AgentPoseError draw_agent_pose_bias(const Session& s) {
  const RecorderConfig& cfg = s.cfg;
  AgentPoseError e{Rng(derive_seed(cfg.seed, {kAgentPose})), {}};
  for (std::size_t a = 0; a < s.scenario().agents.size(); ++a)
    e.bias.emplace_back(e.rng.gaussian(cfg.agent_pos_bias_sigma), e.rng.gaussian(cfg.agent_pos_bias_sigma),
                        e.rng.gaussian(cfg.agent_yaw_bias_sigma_deg * M_PI / 180.0));
  return e;
}

// Ego LiDAR sweep (raw: each point in the sensor frame at its own firing time) and disparity map.
void record_ego_frame(Session& s, int i, double t, FrameProducts& out) {
  const Scenario& sc = s.scenario();
  Rng rng(derive_seed(s.cfg.seed, {kEgoLidar, static_cast<std::uint64_t>(i)}));
  render_lidar_sweep(s.world(), s.ego_cfg, [&](double tt) { return sc.ego.body_to_enu(tt); }, t, s.sim.ego_body, rng, s.scan);
  out.points_per_scan.push_back(static_cast<double>(s.scan.points.size()));
  s.write_cloud(frame_file("ego_lidar", i, "pcdz"), s.scan);
  out.ground_truth.push_back({t, sc.ego.body_to_enu(t)});

  if (s.cfg.stereo) {
    Rng srng(derive_seed(s.cfg.seed, {kStereo, static_cast<std::uint64_t>(i)}));
    render_disparity(s.world(), s.stereo_cfg, sc.ego.body_to_enu(t), t, s.sim.ego_body, srng, s.disparity);
    if (!write_png((s.root / frame_file("stereo", i, "png")).string(), s.disparity, s.err)) s.errors.push_back(s.err);
  }
}

void record_infra_clouds(Session& s, int i, double t, FrameProducts& out) {
  for (std::size_t k = 0; k < s.sites.size(); ++k) {
    LidarConfig icfg = infra_lidar_config(s.cfg.quick);
    icfg.name = s.sites[k].name;
    icfg.mount = Eigen::Isometry3d::Identity();
    Rng irng(derive_seed(s.cfg.seed, {kInfra, k, static_cast<std::uint64_t>(i)}));
    const Eigen::Isometry3d pose = s.sites[k].sensor_to_enu;
    render_lidar_sweep(s.world(), icfg, [&](double) { return pose; }, t, -1, irng, s.scan);
    const std::string rel = "infra/" + s.sites[k].name + frame_file("", i, "pcdz");
    s.write_cloud(rel, s.scan);
    Json e = Json::object();
    e["sensor"] = s.sites[k].name;
    e["kind"] = "infra";
    e["stamp_s"] = t;
    e["file"] = rel;
    e["points"] = s.scan.points.size();
    e["sensor_pose_enu"] = pose_to_json(pose);
    e["true_sensor_pose_enu"] = pose_to_json(pose);
    out.map_clouds.push_back(std::move(e));
  }
}

void record_agent_clouds(Session& s, int i, double t, AgentPoseError& pose_error, FrameProducts& out) {
  const RecorderConfig& cfg = s.cfg;
  for (std::size_t a = 0; a < s.scenario().agents.size(); ++a) {
    const Trajectory& traj = s.scenario().agents[a];
    const LidarConfig acfg = agent_lidar_config(cfg.quick);
    Rng arng(derive_seed(cfg.seed, {kAgentLidar, a, static_cast<std::uint64_t>(i)}));
    render_lidar_sweep(s.world(), acfg, [&](double tt) { return traj.body_to_enu(tt); }, t, s.sim.agent_bodies[a], arng,
                       s.scan);
    // The agent shares a motion-compensated sweep: points re-expressed in the sensor frame at
    // the stamp with its own (accurate over 0.1 s) odometry; per-point times are kept.
    const Eigen::Isometry3d sensor_at_stamp_inv = (traj.body_to_enu(t) * acfg.mount).inverse();
    for (auto& p : s.scan.points) {
      const Eigen::Isometry3d at_fire = traj.body_to_enu(t + p.t) * acfg.mount;
      p.p = (sensor_at_stamp_inv * (at_fire * p.p.cast<double>())).cast<float>();
    }
    const std::string name = "agent_" + std::to_string(a);
    const std::string rel = "agents/" + name + frame_file("", i, "pcdz");
    s.write_cloud(rel, s.scan);
    // Reported pose = truth + bias + noise (the agent's own localization error).
    PlanarPose rep = traj.pose(t);
    rep.x += pose_error.bias[a].x() + pose_error.rng.gaussian(cfg.agent_pos_noise_sigma);
    rep.y += pose_error.bias[a].y() + pose_error.rng.gaussian(cfg.agent_pos_noise_sigma);
    rep.yaw += pose_error.bias[a].z() + pose_error.rng.gaussian(cfg.agent_yaw_noise_sigma_deg * M_PI / 180.0);
    Json e = Json::object();
    e["sensor"] = name + "_lidar";
    e["kind"] = "agent";
    e["agent"] = name;
    e["stamp_s"] = t;
    e["file"] = rel;
    e["points"] = s.scan.points.size();
    e["sensor_pose_enu"] = pose_to_json(cfg.terrain.vehicle_pose(rep.x, rep.y, rep.yaw) * acfg.mount);
    e["true_sensor_pose_enu"] = pose_to_json(traj.body_to_enu(t) * acfg.mount);
    out.map_clouds.push_back(std::move(e));
  }
}

// The 10 Hz loop: every frame the ego sensors, every map_every-th frame the map clouds.
bool record_frames(Session& s, FrameProducts& out, std::string& error, const std::function<void(int, int)>& progress) {
  AgentPoseError pose_error = draw_agent_pose_bias(s);
  for (int i = 0; i < s.frames; ++i) {
    const double t = i * s.dt_frame;
    record_ego_frame(s, i, t, out);
    if (i % s.map_every == 0) {
      record_infra_clouds(s, i, t, out);
      if (s.agents) record_agent_clouds(s, i, t, pose_error, out);
    }
    if (s.failed(error)) return false;
    if (progress) progress(i + 1, s.frames);
  }
  return true;
}

// Ground truth: 10 Hz at the frame stamps, 100 Hz for vehicle signals, and the agents.
void write_ground_truth(Session& s, const std::vector<TimedPose>& gt) {
  const Scenario& sc = s.scenario();
  if (!write_tum((s.root / "ground_truth.tum").string(), gt, s.err)) s.errors.push_back(s.err);
  std::vector<TimedPose> gt100;
  const int n100 = static_cast<int>(std::lround(sc.duration * 100.0));
  for (int k = 0; k < n100; ++k) gt100.push_back({k * 0.01, sc.ego.body_to_enu(k * 0.01)});
  if (!write_tum((s.root / "ground_truth_100hz.tum").string(), gt100, s.err)) s.errors.push_back(s.err);
  for (std::size_t a = 0; a < sc.agents.size(); ++a) {
    std::vector<TimedPose> agt;
    for (int f = 0; f < s.frames; ++f) agt.push_back({f * s.dt_frame, sc.agents[a].body_to_enu(f * s.dt_frame)});
    if (!write_tum((s.root / ("agent_" + std::to_string(a) + "_ground_truth.tum")).string(), agt, s.err))
      s.errors.push_back(s.err);
  }
}

const Eigen::Vector3d kAntennaInBody(0.0, 0.0, 1.75);

// GNSS fixes (host_sim/gnss): gnss_fixes.txt, the summary's statistics and the manifest entry.
std::vector<GnssFix> record_gnss(Session& s, RecordingSummary& summary, Json& gnss_json) {
  const RecorderConfig& cfg = s.cfg;
  std::vector<GnssFix> fixes;
  const v2xloc::GeodeticOrigin origin = v2xloc::make_geodetic_origin(cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_m);
  const GnssDrive drive = simulate_gnss_drive(s.scenario(), s.world(), origin, cfg.seed, cfg.gnss_rate_hz, kAntennaInBody);
  std::string csv = "# t lat_deg lon_deg alt_m h_acc_m v_acc_m num_sats hdop pdop valid east_m north_m up_m true_east_m true_north_m"
                    " vel_east vel_north speed_acc velocity_valid true_vel_east true_vel_north\n";
  for (std::size_t k = 0; k < drive.fixes.size(); ++k) {
    const GnssFix& f = drive.fixes[k];
    const Eigen::Vector3d& ant = drive.true_antenna[k];
    const Eigen::Vector3d& vel = drive.true_velocity[k];
    char line[512];
    std::snprintf(line, sizeof line,
                  "%.3f %.9f %.9f %.3f %.3f %.3f %d %.2f %.2f %d %.3f %.3f %.3f %.3f %.3f %.3f %.3f %.3f %d %.3f %.3f\n", f.t,
                  f.lat_deg, f.lon_deg, f.alt_m, f.h_acc_m, f.v_acc_m, f.num_sats, f.hdop, f.pdop, f.valid ? 1 : 0,
                  f.enu_estimate.x(), f.enu_estimate.y(), f.enu_estimate.z(), ant.x(), ant.y(), f.vel_east, f.vel_north,
                  f.speed_acc_mps, f.velocity_valid ? 1 : 0, vel.x(), vel.y());
    csv += line;
    fixes.push_back(f);
  }
  const int valid = drive.valid;
  if (!write_text_file((s.root / "gnss_fixes.txt").string(), csv, s.err)) s.errors.push_back(s.err);
  summary.gnss_fixes = valid;
  summary.gnss_mean_h_error = drive.mean_h_error;
  summary.gnss_max_h_error = drive.max_h_error;
  summary.hdop_min = drive.hdop_min;
  summary.hdop_max = drive.hdop_max;
  gnss_json = Json::object();
  gnss_json["file"] = "gnss_fixes.txt";
  gnss_json["note"] = "truth-side diagnostics of the GNSS model; the ego receives the fixes on CAN";
  gnss_json["rate_hz"] = cfg.gnss_rate_hz;
  gnss_json["epoch_offset_s"] = s.scenario().gnss_epoch_offset_s;
  gnss_json["antenna_in_body"] = Json(std::vector<double>{kAntennaInBody.x(), kAntennaInBody.y(), kAntennaInBody.z()});
  gnss_json["valid_fixes"] = valid;
  gnss_json["mean_horizontal_error_m"] = summary.gnss_mean_h_error;
  gnss_json["max_horizontal_error_m"] = summary.gnss_max_h_error;
  gnss_json["hdop_min"] = summary.hdop_min;
  gnss_json["hdop_max"] = summary.hdop_max;
  gnss_json["mean_velocity_error_mps"] = drive.mean_velocity_error;
  gnss_json["max_velocity_error_mps"] = drive.max_velocity_error;
  return fixes;
}

// CAN log: vehicle motion (wheel speed, yaw rate from host_sim/vehicle's model) at the vehicle rate
// and the GNSS fixes (host_sim/recording/can_log_writer.hpp).
void write_can_log(Session& s, const std::vector<GnssFix>& fixes, Json& can_json) {
  const RecorderConfig& cfg = s.cfg;
  const Scenario& sc = s.scenario();
  VehicleSignalSimulator veh(VehicleSignalConfig{}, derive_seed(cfg.seed, {kVehicle}));
  const int nv = static_cast<int>(std::floor(sc.duration * cfg.vehicle_rate_hz + 1e-9));
  std::vector<VehicleSignals> vehicle;
  for (int k = 0; k < nv; ++k) {
    const double tv = k / cfg.vehicle_rate_hz;
    const VehicleState st = sc.ego.state(tv);
    vehicle.push_back(veh.sample(tv, st.speed, st.yaw_rate));
  }
  if (!write_gnss_vehicle_can_log((s.root / "gnss_vehicle.log").string(), "gnss_vehicle.log", cfg.time_origin_unix_s,
                                  vehicle, fixes, can_json, s.err)) {
    s.errors.push_back(s.err);
  }
}

// The ego IMU's HID input reports (imu_reports.hpp), from the ego's true trajectory.
void write_imu_reports(Session& s) {
  if (!s.cfg.imu) return;
  const Scenario& sc = s.scenario();
  const PoseAt pose = [&sc](double t) { return sc.ego.body_to_enu(t); };
  const ImuReportStream stream =
      simulate_imu_reports(ImuConfig{}, derive_seed(s.cfg.seed, {kImu}), pose, sc.duration, s.cfg.time_origin_unix_s);
  if (!write_text_file((s.root / kImuReportsFile).string(), imu_reports_text(stream.reports), s.err)) {
    s.errors.push_back(s.err);
  }
}

Json imu_json() {
  const ImuConfig c;
  constexpr double kDeg = 180.0 / M_PI;
  Json j = Json::object();
  j["name"] = "ego_imu";
  j["type"] = "imu";
  j["carrier"] = "ego";
  j["mount_in_body"] = pose_to_json(c.mount);
  j["rate_hz"] = c.rate_hz;
  j["report_format"] = "hal/HID_IMU_REPORT.md input report 1; sensor time = Unix us mod 2^32 (time-synced)";
  j["gyro_noise_density_dps_rthz"] = c.gyro_noise_density * kDeg;
  j["gyro_turn_on_bias_sigma_dps"] = c.gyro_turn_on_bias_sigma * kDeg;
  j["gyro_bias_instability_dph"] = c.gyro_bias_instability * kDeg * 3600.0;
  j["accel_noise_density_ug_rthz"] = c.accel_noise_density / 9.80665 * 1e6;
  j["accel_turn_on_bias_sigma_mg"] = c.accel_turn_on_bias_sigma / 9.80665 * 1e3;
  j["model"] = "host_sim/README.md (IMU)";
  return j;
}

void summarize_scans(const std::vector<double>& pts_per_scan, RecordingSummary& summary) {
  if (pts_per_scan.empty()) return;
  double sum = 0;
  for (double v : pts_per_scan) sum += v;
  summary.points_per_scan_mean = sum / static_cast<double>(pts_per_scan.size());
  summary.points_per_scan_min = *std::min_element(pts_per_scan.begin(), pts_per_scan.end());
  summary.points_per_scan_max = *std::max_element(pts_per_scan.begin(), pts_per_scan.end());
}

Json manifest_files(const Session& s) {
  Json files = Json::object();
  files["ego_scan_pattern"] = "ego_lidar/%06d.pcdz";
  files["ego_scan_fields"] = std::string(kCloudFields) + "; sensor frame at each point's firing time; t = seconds since the frame stamp";
  if (s.cfg.stereo) files["disparity_pattern"] = "stereo/%06d.png";
  files["frame_stamp"] = "frame index / frame_rate_hz";
  files["ground_truth"] = "ground_truth.tum";
  files["ground_truth_100hz"] = "ground_truth_100hz.tum";
  Json agt = Json::array();
  for (std::size_t a = 0; a < s.scenario().agents.size(); ++a) agt.push_back(Json("agent_" + std::to_string(a) + "_ground_truth.tum"));
  files["agent_ground_truth"] = agt;
  files["can_log"] = "gnss_vehicle.log";
  files["trust_list"] = kTrustListFile;
  if (s.cfg.imu) files["imu_reports"] = kImuReportsFile;
  return files;
}

// Each infrastructure unit's surveyed background (sim_background.hpp), rendered in the world
// without its vehicles, written beside the trust list and named on the unit's entry.
bool write_backgrounds(const Session& s, trust::TrustList& list, std::string& error) {
  IntersectionWorld survey;  // the recording's world (same seed), no dynamic bodies
  WorldConfig world_config;
  world_config.seed = s.cfg.seed;
  world_config.terrain = s.cfg.terrain;
  build_intersection_world(world_config, survey);
  for (std::size_t k = 0; k < s.sites.size(); ++k) {
    std::uint32_t id = 0;
    if (!sim_sender_id("infra", s.sites[k].name, id)) continue;
    LidarConfig cfg = infra_lidar_config(s.cfg.quick);
    cfg.name = s.sites[k].name;
    cfg.mount = Eigen::Isometry3d::Identity();
    SimBackground bg;
    if (!render_background(survey.world, cfg, s.sites[k].sensor_to_enu, s.cfg.seed, k, config::kBackgroundFileCells, bg,
                           error)) {
      return false;
    }
    for (std::size_t i = 0; i < list.count; ++i) {
      if (list.signers[i].sender_id == id && !write_background(s.root.string(), cfg.name, bg, list.signers[i], error)) {
        return false;
      }
    }
  }
  return true;
}

// trust_list.txt: every map-cloud sensor's deterministic test key (sim_trust.hpp), every
// infrastructure sensor's surveyed pose and background, the list the firmware is provisioned with
// when this recording is replayed.
bool write_trust_list(Session& s, std::string& error) {
  std::vector<SimSigner> signers;
  for (const auto& site : s.sites) {
    SimSigner signer;
    if (!sim_signer("infra", site.name, signer)) continue;
    signer.surveyed = true;
    signer.survey = surveyed_pose(site.sensor_to_enu);
    signers.push_back(signer);
  }
  if (s.agents) {
    for (std::size_t a = 0; a < s.scenario().agents.size(); ++a) {
      SimSigner signer;
      if (sim_signer("agent", "agent_" + std::to_string(a) + "_lidar", signer)) signers.push_back(signer);
    }
  }
  trust::TrustList list = trust_list_of(signers);
  return write_backgrounds(s, list, error) &&
         write_text_file((s.root / kTrustListFile).string(), trust_list_text(list), error);
}

Json manifest_sensors(const Session& s) {
  const RecorderConfig& cfg = s.cfg;
  const Scenario& sc = s.scenario();
  Json sensors = Json::array();
  {
    Json j = lidar_json(s.ego_cfg);
    j["name"] = "ego_lidar";
    j["carrier"] = "ego";
    j["mount_in_body"] = pose_to_json(s.ego_cfg.mount);
    sensors.push_back(std::move(j));
  }
  if (cfg.stereo) {
    const StereoCalibration cal = s.stereo_cfg.calibration();
    Json j = Json::object();
    j["name"] = "ego_stereo";
    j["type"] = "stereo_disparity";
    j["carrier"] = "ego";
    j["width"] = cal.width;
    j["height"] = cal.height;
    j["fx"] = cal.fx;
    j["fy"] = cal.fy;
    j["cx"] = cal.cx;
    j["cy"] = cal.cy;
    j["baseline_m"] = cal.baseline;
    j["camera_to_body"] = pose_to_json(cal.camera_to_body);
    j["camera_frame"] = "left camera optical frame: x right, y down, z forward";
    j["disparity_sigma_px"] = s.stereo_cfg.disparity_sigma;
    j["rate_hz"] = sc.frame_rate;
    sensors.push_back(std::move(j));
  }
  for (const auto& site : s.sites) {
    Json j = lidar_json(infra_lidar_config(cfg.quick));
    j["name"] = site.name;
    j["carrier"] = "infrastructure";
    j["rate_hz_published"] = sc.frame_rate / s.map_every;
    j["surveyed_pose_enu"] = pose_to_json(site.sensor_to_enu);
    sensors.push_back(std::move(j));
  }
  if (cfg.imu) sensors.push_back(imu_json());
  if (s.agents) {
    for (std::size_t a = 0; a < sc.agents.size(); ++a) {
      const LidarConfig acfg = agent_lidar_config(cfg.quick);
      Json j = lidar_json(acfg);
      j["name"] = "agent_" + std::to_string(a) + "_lidar";
      j["carrier"] = "agent_" + std::to_string(a);
      j["rate_hz_published"] = sc.frame_rate / s.map_every;
      j["mount_in_body"] = pose_to_json(acfg.mount);
      j["motion_compensated"] = true;
      sensors.push_back(std::move(j));
    }
  }
  return sensors;
}

Json build_manifest(const Session& s, const FrameProducts& products, const RecordingSummary& summary,
                    const Json& gnss_json, const Json& can_json) {
  const RecorderConfig& cfg = s.cfg;
  const Scenario& sc = s.scenario();
  Json m = Json::object();
  m["format"] = "v2xloc-recording";
  m["format_version"] = RecordingReader::kFormatVersion;
  Json scj = Json::object();
  scj["id"] = sc.id;
  scj["name"] = sc.name;
  scj["description"] = sc.description;
  m["scenario"] = scj;
  m["permutation"] = permutation_name(cfg.permutation);
  m["seed"] = static_cast<double>(cfg.seed);
  m["quick"] = cfg.quick;
  m["duration_s"] = sc.duration;
  if (!cfg.terrain.flat()) {
    Json terrain = Json::object();
    terrain["grade"] = cfg.terrain.grade;
    terrain["grade_heading_deg"] = cfg.terrain.grade_heading * 180.0 / M_PI;
    terrain["crown"] = cfg.terrain.crown;
    terrain["road_half_width_m"] = cfg.terrain.road_half_width;
    m["terrain"] = terrain;
  }
  m["frame_rate_hz"] = sc.frame_rate;
  m["frame_count"] = s.frames;
  m["time_origin_unix_s"] = cfg.time_origin_unix_s;
  Json geo = Json::object();
  geo["lat_deg"] = cfg.origin_lat_deg;
  geo["lon_deg"] = cfg.origin_lon_deg;
  geo["alt_m"] = cfg.origin_alt_m;
  m["geodetic_origin"] = geo;
  Json units = Json::object();
  units["frame"] = "local ENU at the intersection centre: x east, y north, z up (metres)";
  units["body_frame"] = "vehicle body: x forward, y left, z up, origin on the ground at the footprint centre";
  units["time"] = "seconds since the recording start; unix time = time_origin_unix_s + t";
  units["pose"] = "[x, y, z, qx, qy, qz, qw], child frame in parent frame";
  units["intensity"] = "[0, 1], reflectivity * cos(incidence) + noise";
  units["disparity"] = "uint16 PNG, disparity_px = value / 256, 0 = invalid";
  Json quantisation = Json::object();
  quantisation["xyz_step_m"] = kCloudQuantisation.xyz_step_m;
  quantisation["intensity_step"] = kCloudQuantisation.intensity_step;
  quantisation["time_step_s"] = kCloudQuantisation.time_step_s;
  quantisation["note"] = "stored integer x step; each .pcdz file's SCALE line carries the same steps";
  units["cloud_quantisation"] = quantisation;
  m["units"] = units;
  m["files"] = manifest_files(s);
  m["sensors"] = manifest_sensors(s);
  Json mc = Json::object();
  mc["fields"] = std::string(kCloudFields) + ", sensor frame at stamp_s";
  mc["pose_note"] = "sensor_pose_enu is what the sender reports (agents: with their localization error); true_sensor_pose_enu is the truth";
  mc["clouds"] = products.map_clouds;
  m["map_clouds"] = mc;
  if (!gnss_json.is_null()) m["gnss"] = gnss_json;
  if (!can_json.is_null()) m["can_log"] = can_json;
  Json stats = Json::object();
  stats["ego_points_per_scan_mean"] = summary.points_per_scan_mean;
  stats["ego_points_per_scan_min"] = summary.points_per_scan_min;
  stats["ego_points_per_scan_max"] = summary.points_per_scan_max;
  m["stats"] = stats;
  return m;
}

}  // namespace

std::string recording_name(int scenario, Permutation p) {
  return "sim" + std::to_string(scenario) + "_" + permutation_name(p);
}

std::string RecordingSummary::one_line() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%-22s frames %4d  pts/scan %6.0f (%.0f-%.0f)  map clouds %4d  GNSS h-err mean %5.2f m max %5.2f m"
                "  HDOP %.1f-%.1f  %.1f MB  %.1f s",
                name.c_str(), frames, points_per_scan_mean, points_per_scan_min, points_per_scan_max, map_clouds,
                gnss_mean_h_error, gnss_max_h_error, hdop_min, hdop_max, static_cast<double>(bytes) / 1e6, seconds);
  return buf;
}

bool generate_recording(const RecorderConfig& cfg, RecordingSummary& summary, std::string& error,
                        const std::function<void(int, int)>& progress) {
  const auto wall0 = std::chrono::steady_clock::now();
  // Simulation holds the whole world: on the heap, not the stack.
  auto session = std::make_unique<Session>(cfg);
  Session& s = *session;
  if (!setup(s, error) || !create_folders(s, error)) return false;

  FrameProducts products;
  if (!record_frames(s, products, error, progress)) return false;
  write_ground_truth(s, products.ground_truth);

  summary = RecordingSummary{};
  Json gnss_json;
  Json can_json;
  const std::vector<GnssFix> fixes = record_gnss(s, summary, gnss_json);
  write_can_log(s, fixes, can_json);
  write_imu_reports(s);
  if (s.failed(error)) return false;

  summary.name = recording_name(cfg.scenario, cfg.permutation);
  summary.frames = s.frames;
  summary.map_clouds = static_cast<int>(products.map_clouds.size());
  summarize_scans(products.points_per_scan, summary);
  if (!write_trust_list(s, error)) return false;
  const Json manifest = build_manifest(s, products, summary, gnss_json, can_json);
  if (!write_text_file((s.root / "manifest.json").string(), manifest.dump(2) + "\n", error)) return false;

  summary.bytes = folder_bytes(s.root);
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return true;
}

}  // namespace v2xloc::sim
