#include "host_sim/recording/recorder.hpp"

#include "host_sim/common/text_file.hpp"
#include "host_sim/common/png.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/topview.hpp"
#include "host_sim/scenario/simulation.hpp"
#include "host_sim/sensors/lidar.hpp"
#include "host_sim/sensors/stereo.hpp"
#include "host_sim/cloud_io/pcd.hpp"

#if V2XLOC_SIM_HAVE_GNSS
#include "host_sim/gnss/gnss_simulator.hpp"
#include "host_sim/recording/gnss_drive.hpp"
#endif
#if V2XLOC_SIM_HAVE_VEHICLE
#include "host_sim/vehicle/vehicle_signals.hpp"
#endif
#if V2XLOC_SIM_HAVE_CANLOG
#include "firmware/protocol/can_messages.hpp"
#include "host_sim/canlog/candump_log.hpp"
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

// Stream ids for derive_seed (each sensor/frame gets its own noise stream).
enum Stream : std::uint64_t { kEgoLidar = 1, kStereo = 2, kInfra = 3, kAgentLidar = 4, kAgentPose = 5, kVehicle = 7 /* 6: GNSS, gnss_drive.cpp */ };

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

Eigen::Isometry3d planar(const PlanarPose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(p.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(p.x, p.y, 0.0);
  return T;
}

std::uint64_t folder_bytes(const fs::path& dir) {
  std::uint64_t total = 0;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file()) total += e.file_size();
  return total;
}

}  // namespace

std::string recording_name(int scenario, Permutation p) {
  return "sim" + std::to_string(scenario) + "_" + permutation_name(p);
}

std::string RecordingSummary::one_line() const {
  char buf[512];
  int n = std::snprintf(buf, sizeof buf, "%-22s frames %4d  pts/scan %6.0f (%.0f-%.0f)  map clouds %4d", name.c_str(),
                        frames, points_per_scan_mean, points_per_scan_min, points_per_scan_max, map_clouds);
  if (has_gnss) {
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n),
                       "  GNSS h-err mean %5.2f m max %5.2f m  HDOP %.1f-%.1f", gnss_mean_h_error, gnss_max_h_error,
                       hdop_min, hdop_max);
  } else {
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), "  GNSS n/a");
  }
  std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), "  %.1f MB  %.1f s", static_cast<double>(bytes) / 1e6,
                seconds);
  return buf;
}

bool generate_recording(const RecorderConfig& cfg, RecordingSummary& summary, std::string& error,
                        const std::function<void(int, int)>& progress) {
  const auto wall0 = std::chrono::steady_clock::now();
  if (cfg.scenario < 0 || cfg.scenario >= kScenarioCount) {
    error = "scenario must be 0..3";
    return false;
  }
  const double duration = cfg.duration > 0 ? cfg.duration : (cfg.quick ? 3.0 : 0.0);
  Simulation sim;
  build_simulation(cfg.scenario, cfg.seed, duration, WorldConfig{}, sim);
  const Scenario& sc = sim.scenario;
  World& world = sim.iw.world;

  const fs::path root(cfg.out_dir);
  std::error_code ec;
  fs::create_directories(root / "ego_lidar", ec);
  if (cfg.stereo) fs::create_directories(root / "stereo", ec);
  if (ec) {
    error = "cannot create " + root.string() + ": " + ec.message();
    return false;
  }

  const LidarConfig ego_cfg = ego_lidar_config(cfg.quick);
  const StereoConfig stereo_cfg = ego_stereo_config(cfg.quick);
  const std::vector<InfraSite> sites = infra_sites(cfg.permutation);
  const bool agents = uses_agents(cfg.permutation);
  for (const auto& s : sites) fs::create_directories(root / "infra" / s.name, ec);
  if (agents)
    for (std::size_t a = 0; a < sc.agents.size(); ++a) fs::create_directories(root / "agents" / ("agent_" + std::to_string(a)), ec);

  const int frames = sc.frame_count();
  const double dt_frame = 1.0 / sc.frame_rate;
  const int map_every = std::max(1, static_cast<int>(std::lround(sc.frame_rate / cfg.map_rate_hz)));

  // Agent self-localization bias (per run).
  Rng pose_rng(derive_seed(cfg.seed, {kAgentPose}));
  std::vector<Eigen::Vector3d> agent_bias;  // dx, dy, dyaw
  for (std::size_t a = 0; a < sc.agents.size(); ++a)
    agent_bias.emplace_back(pose_rng.gaussian(cfg.agent_pos_bias_sigma), pose_rng.gaussian(cfg.agent_pos_bias_sigma),
                            pose_rng.gaussian(cfg.agent_yaw_bias_sigma_deg * M_PI / 180.0));

  Json map_clouds = Json::array();
  std::vector<TimedPose> gt;
  std::vector<double> pts_per_scan;
  std::vector<std::string> errors;
  LidarScan scan;
  Image16 disparity;
  std::string err;
  auto write_cloud = [&](const std::string& rel, const LidarScan& s) {
    const cloud_io::PointCloud c = to_cloud(s);
    if (!cloud_io::write_pcd((root / rel).string(), c, cloud_io::PcdEncoding::kBinaryCompressed, err)) errors.push_back(err);
  };

  for (int i = 0; i < frames; ++i) {
    const double t = i * dt_frame;
    // Ego LiDAR sweep (raw: each point in the sensor frame at its own firing time).
    Rng rng(derive_seed(cfg.seed, {kEgoLidar, static_cast<std::uint64_t>(i)}));
    render_lidar_sweep(world, ego_cfg, [&](double tt) { return sc.ego.body_to_enu(tt); }, t, sim.ego_body, rng, scan);
    pts_per_scan.push_back(static_cast<double>(scan.points.size()));
    write_cloud(frame_file("ego_lidar", i, "pcd"), scan);
    gt.push_back({t, sc.ego.body_to_enu(t)});

    if (cfg.stereo) {
      Rng srng(derive_seed(cfg.seed, {kStereo, static_cast<std::uint64_t>(i)}));
      render_disparity(world, stereo_cfg, sc.ego.body_to_enu(t), t, sim.ego_body, srng, disparity);
      if (!write_png((root / frame_file("stereo", i, "png")).string(), disparity, err)) errors.push_back(err);
    }

    if (i % map_every == 0) {
      for (std::size_t k = 0; k < sites.size(); ++k) {
        LidarConfig icfg = infra_lidar_config(cfg.quick);
        icfg.name = sites[k].name;
        icfg.mount = Eigen::Isometry3d::Identity();
        Rng irng(derive_seed(cfg.seed, {kInfra, k, static_cast<std::uint64_t>(i)}));
        const Eigen::Isometry3d pose = sites[k].sensor_to_enu;
        render_lidar_sweep(world, icfg, [&](double) { return pose; }, t, -1, irng, scan);
        const std::string rel = "infra/" + sites[k].name + frame_file("", i, "pcd");
        write_cloud(rel, scan);
        Json e = Json::object();
        e["sensor"] = sites[k].name;
        e["kind"] = "infra";
        e["stamp_s"] = t;
        e["file"] = rel;
        e["points"] = scan.points.size();
        e["sensor_pose_enu"] = pose_to_json(pose);
        e["true_sensor_pose_enu"] = pose_to_json(pose);
        map_clouds.push_back(std::move(e));
      }
      if (agents) {
        for (std::size_t a = 0; a < sc.agents.size(); ++a) {
          const Trajectory& traj = sc.agents[a];
          const LidarConfig acfg = agent_lidar_config(cfg.quick);
          Rng arng(derive_seed(cfg.seed, {kAgentLidar, a, static_cast<std::uint64_t>(i)}));
          render_lidar_sweep(world, acfg, [&](double tt) { return traj.body_to_enu(tt); }, t,
                             sim.agent_bodies[a], arng, scan);
          // The agent shares a motion-compensated sweep: points re-expressed in the sensor frame at
          // the stamp with its own (accurate over 0.1 s) odometry; per-point times are kept.
          const Eigen::Isometry3d sensor_at_stamp_inv = (traj.body_to_enu(t) * acfg.mount).inverse();
          for (auto& p : scan.points) {
            const Eigen::Isometry3d at_fire = traj.body_to_enu(t + p.t) * acfg.mount;
            p.p = (sensor_at_stamp_inv * (at_fire * p.p.cast<double>())).cast<float>();
          }
          const std::string name = "agent_" + std::to_string(a);
          const std::string rel = "agents/" + name + frame_file("", i, "pcd");
          write_cloud(rel, scan);
          // Reported pose = truth + bias + noise (the agent's own localization error).
          PlanarPose rep = traj.pose(t);
          rep.x += agent_bias[a].x() + pose_rng.gaussian(cfg.agent_pos_noise_sigma);
          rep.y += agent_bias[a].y() + pose_rng.gaussian(cfg.agent_pos_noise_sigma);
          rep.yaw += agent_bias[a].z() + pose_rng.gaussian(cfg.agent_yaw_noise_sigma_deg * M_PI / 180.0);
          Json e = Json::object();
          e["sensor"] = name + "_lidar";
          e["kind"] = "agent";
          e["agent"] = name;
          e["stamp_s"] = t;
          e["file"] = rel;
          e["points"] = scan.points.size();
          e["sensor_pose_enu"] = pose_to_json(planar(rep) * acfg.mount);
          e["true_sensor_pose_enu"] = pose_to_json(traj.body_to_enu(t) * acfg.mount);
          map_clouds.push_back(std::move(e));
        }
      }
    }
    if (!errors.empty()) {
      error = errors.front();
      return false;
    }
    if (progress) progress(i + 1, frames);
  }

  // Ground truth: 10 Hz at the frame stamps, 100 Hz for vehicle signals, and the agents.
  if (!write_tum((root / "ground_truth.tum").string(), gt, err)) errors.push_back(err);
  std::vector<TimedPose> gt100;
  const int n100 = static_cast<int>(std::lround(sc.duration * 100.0));
  for (int k = 0; k < n100; ++k) gt100.push_back({k * 0.01, sc.ego.body_to_enu(k * 0.01)});
  if (!write_tum((root / "ground_truth_100hz.tum").string(), gt100, err)) errors.push_back(err);
  for (std::size_t a = 0; a < sc.agents.size(); ++a) {
    std::vector<TimedPose> agt;
    for (int f = 0; f < frames; ++f) agt.push_back({f * dt_frame, sc.agents[a].body_to_enu(f * dt_frame)});
    if (!write_tum((root / ("agent_" + std::to_string(a) + "_ground_truth.tum")).string(), agt, err)) errors.push_back(err);
  }

  // GNSS fixes and vehicle signals (models from host_sim/gnss and host_sim/vehicle).
  TopViewData top;
  summary = RecordingSummary{};
  Json gnss_json;
  Json can_json;
  const Eigen::Vector3d antenna_in_body(0.0, 0.0, 1.75);
#if V2XLOC_SIM_HAVE_GNSS
  std::vector<GnssFix> fixes;
  {
    const v2xloc::GeodeticOrigin origin = v2xloc::make_geodetic_origin(cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_m);
    const GnssDrive drive = simulate_gnss_drive(sc, world, origin, cfg.seed, cfg.gnss_rate_hz, antenna_in_body);
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
      if (f.valid) top.gnss_fixes.push_back(f.enu_estimate.head<2>());
    }
    const int valid = drive.valid;
    if (!write_text_file((root / "gnss_fixes.txt").string(), csv, err)) errors.push_back(err);
    summary.has_gnss = true;
    summary.gnss_fixes = valid;
    summary.gnss_mean_h_error = drive.mean_h_error;
    summary.gnss_max_h_error = drive.max_h_error;
    summary.hdop_min = drive.hdop_min;
    summary.hdop_max = drive.hdop_max;
    gnss_json = Json::object();
    gnss_json["file"] = "gnss_fixes.txt";
    gnss_json["note"] = "truth-side diagnostics of the GNSS model; the ego receives the fixes on CAN";
    gnss_json["rate_hz"] = cfg.gnss_rate_hz;
    gnss_json["epoch_offset_s"] = sc.gnss_epoch_offset_s;
    gnss_json["antenna_in_body"] = Json(std::vector<double>{antenna_in_body.x(), antenna_in_body.y(), antenna_in_body.z()});
    gnss_json["valid_fixes"] = valid;
    gnss_json["mean_horizontal_error_m"] = summary.gnss_mean_h_error;
    gnss_json["max_horizontal_error_m"] = summary.gnss_max_h_error;
    gnss_json["hdop_min"] = summary.hdop_min;
    gnss_json["hdop_max"] = summary.hdop_max;
    gnss_json["mean_velocity_error_mps"] = drive.mean_velocity_error;
    gnss_json["max_velocity_error_mps"] = drive.max_velocity_error;
  }

#if V2XLOC_SIM_HAVE_CANLOG && V2XLOC_SIM_HAVE_VEHICLE
  // CAN log: vehicle motion at 100 Hz and the GNSS fixes (position, status, time + DOP), merged in
  // time order, time stamps = time_origin_unix_s + t.
  {
    struct Timed {
      std::int64_t us;
      int order;
      hal::CanFrame frame;
    };
    std::vector<Timed> out;
    VehicleSignalSimulator veh(VehicleSignalConfig{}, derive_seed(cfg.seed, {kVehicle}));
    const int nv = static_cast<int>(std::floor(sc.duration * cfg.vehicle_rate_hz + 1e-9));
    for (int k = 0; k < nv; ++k) {
      const double tv = k / cfg.vehicle_rate_hz;
      const VehicleState st = sc.ego.state(tv);
      const VehicleSignals sig = veh.sample(tv, st.speed, st.yaw_rate);
      protocol::VehicleMotion vm;
      vm.wheel_speed_mps = sig.wheel_speed_mps;
      vm.yaw_rate_rps = sig.yaw_rate_rps;
      vm.speed_valid = sig.speed_valid;
      vm.yaw_rate_valid = sig.yaw_rate_valid;
      vm.counter = static_cast<std::uint8_t>(sig.counter % protocol::kCounterModulo);
      out.push_back({candump_timestamp_us(cfg.time_origin_unix_s + tv), 0, protocol::pack(vm)});
    }
    std::uint8_t gnss_counter = 0;
    for (const GnssFix& f : fixes) {
      const double unix_t = cfg.time_origin_unix_s + f.t;
      const std::int64_t us = candump_timestamp_us(unix_t);
      protocol::GnssPosition pos;
      pos.lat_deg = f.lat_deg;
      pos.lon_deg = f.lon_deg;
      protocol::GnssStatus status;
      status.alt_m = f.alt_m;
      status.h_acc_m = f.h_acc_m;
      status.v_acc_m = f.v_acc_m;
      status.num_sats = static_cast<std::uint8_t>(std::clamp(f.num_sats, 0, 63));
      status.fix_type = f.valid ? protocol::GnssFixType::kFix3D : protocol::GnssFixType::kNoFix;
      status.counter = gnss_counter;
      gnss_counter = static_cast<std::uint8_t>((gnss_counter + 1) % protocol::kCounterModulo);
      protocol::GnssTimeDop td;
      // GPS time = unix time - GPS epoch (1980-01-06) + leap seconds (18 s since 2017).
      const double gps_s = unix_t - 315964800.0 + 18.0;
      td.week = static_cast<std::uint16_t>(std::floor(gps_s / 604800.0));
      td.time_of_week_s = gps_s - 604800.0 * td.week;
      td.hdop = f.hdop;
      td.pdop = f.pdop;
      protocol::GnssVelocity vel;
      vel.vel_east_mps = f.vel_east;
      vel.vel_north_mps = f.vel_north;
      vel.vel_up_mps = f.vel_up;
      vel.speed_acc_mps = f.speed_acc_mps;
      vel.valid = f.velocity_valid;
      vel.counter = status.counter;  // one counter step per fix, like the status frame
      if (f.valid) out.push_back({us, 1, protocol::pack(pos)});
      out.push_back({us, 2, protocol::pack(status)});
      out.push_back({us, 3, protocol::pack(vel)});
      out.push_back({us, 4, protocol::pack(td)});
    }
    std::stable_sort(out.begin(), out.end(),
                     [](const Timed& a, const Timed& b) { return a.us < b.us || (a.us == b.us && a.order < b.order); });
    std::ofstream log(root / "gnss_vehicle.log", std::ios::binary);
    CandumpWriter writer(log, "can0");
    for (const auto& e : out) writer.write(e.us, e.frame);
    if (!log) errors.push_back("cannot write gnss_vehicle.log");
    summary.has_can_log = true;
    can_json = Json::object();
    can_json["file"] = "gnss_vehicle.log";
    can_json["format"] = "candump -L: (unix_seconds.microseconds) can0 ID#HEXDATA";
    can_json["frames"] = writer.frames_written();
    can_json["vehicle_motion"] = "0x120 at 100 Hz (wheel speed, yaw rate)";
    can_json["gnss"] = "0x130 position, 0x131 status, 0x133 velocity, 0x132 time + DOP at the GNSS rate";
    can_json["codec"] = "firmware/protocol/can_messages.hpp";
  }
#endif
#endif
  if (!errors.empty()) {
    error = errors.front();
    return false;
  }

  // Manifest.
  Json m = Json::object();
  m["format"] = "v2xloc-recording";
  m["format_version"] = 1;
  Json scj = Json::object();
  scj["id"] = sc.id;
  scj["name"] = sc.name;
  scj["description"] = sc.description;
  m["scenario"] = scj;
  m["permutation"] = permutation_name(cfg.permutation);
  m["seed"] = static_cast<double>(cfg.seed);
  m["quick"] = cfg.quick;
  m["duration_s"] = sc.duration;
  m["frame_rate_hz"] = sc.frame_rate;
  m["frame_count"] = frames;
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
  m["units"] = units;

  Json files = Json::object();
  files["ego_scan_pattern"] = "ego_lidar/%06d.pcd";
  files["ego_scan_fields"] = "x y z intensity t (float32, PCD binary_compressed); sensor frame at each point's firing time; t = seconds since the frame stamp";
  if (cfg.stereo) files["disparity_pattern"] = "stereo/%06d.png";
  files["frame_stamp"] = "frame index / frame_rate_hz";
  files["ground_truth"] = "ground_truth.tum";
  files["ground_truth_100hz"] = "ground_truth_100hz.tum";
  Json agt = Json::array();
  for (std::size_t a = 0; a < sc.agents.size(); ++a) agt.push_back(Json("agent_" + std::to_string(a) + "_ground_truth.tum"));
  files["agent_ground_truth"] = agt;
  files["top_view"] = "topview.png";
  if (summary.has_can_log) files["can_log"] = "gnss_vehicle.log";
  m["files"] = files;

  Json sensors = Json::array();
  {
    Json j = lidar_json(ego_cfg);
    j["name"] = "ego_lidar";
    j["carrier"] = "ego";
    j["mount_in_body"] = pose_to_json(ego_cfg.mount);
    sensors.push_back(std::move(j));
  }
  if (cfg.stereo) {
    const StereoCalibration cal = stereo_cfg.calibration();
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
    j["disparity_sigma_px"] = stereo_cfg.disparity_sigma;
    j["rate_hz"] = sc.frame_rate;
    sensors.push_back(std::move(j));
  }
  for (const auto& s : sites) {
    Json j = lidar_json(infra_lidar_config(cfg.quick));
    j["name"] = s.name;
    j["carrier"] = "infrastructure";
    j["rate_hz_published"] = sc.frame_rate / map_every;
    j["surveyed_pose_enu"] = pose_to_json(s.sensor_to_enu);
    sensors.push_back(std::move(j));
  }
  if (agents) {
    for (std::size_t a = 0; a < sc.agents.size(); ++a) {
      const LidarConfig acfg = agent_lidar_config(cfg.quick);
      Json j = lidar_json(acfg);
      j["name"] = "agent_" + std::to_string(a) + "_lidar";
      j["carrier"] = "agent_" + std::to_string(a);
      j["rate_hz_published"] = sc.frame_rate / map_every;
      j["mount_in_body"] = pose_to_json(acfg.mount);
      j["motion_compensated"] = true;
      sensors.push_back(std::move(j));
    }
  }
  m["sensors"] = sensors;
  Json mc = Json::object();
  mc["fields"] = "x y z intensity t (float32, PCD binary_compressed), sensor frame at stamp_s";
  mc["pose_note"] = "sensor_pose_enu is what the sender reports (agents: with their localization error); true_sensor_pose_enu is the truth";
  mc["clouds"] = map_clouds;
  m["map_clouds"] = mc;
  if (!gnss_json.is_null()) m["gnss"] = gnss_json;
  if (!can_json.is_null()) m["can_log"] = can_json;

  summary.name = recording_name(cfg.scenario, cfg.permutation);
  summary.frames = frames;
  summary.map_clouds = static_cast<int>(map_clouds.size());
  if (!pts_per_scan.empty()) {
    double s = 0;
    for (double v : pts_per_scan) s += v;
    summary.points_per_scan_mean = s / static_cast<double>(pts_per_scan.size());
    summary.points_per_scan_min = *std::min_element(pts_per_scan.begin(), pts_per_scan.end());
    summary.points_per_scan_max = *std::max_element(pts_per_scan.begin(), pts_per_scan.end());
  }
  Json stats = Json::object();
  stats["ego_points_per_scan_mean"] = summary.points_per_scan_mean;
  stats["ego_points_per_scan_min"] = summary.points_per_scan_min;
  stats["ego_points_per_scan_max"] = summary.points_per_scan_max;
  m["stats"] = stats;
  if (!write_text_file((root / "manifest.json").string(), m.dump(2) + "\n", err)) {
    error = err;
    return false;
  }

  if (cfg.top_view) {
    top.title = summary.name;
    for (int k = 0; k <= frames; ++k) {
      const double tt = std::min(k * dt_frame, sc.duration);
      const PlanarPose e = sc.ego.pose(tt);
      top.ego_path.emplace_back(e.x, e.y);
      top.agent_paths.resize(sc.agents.size());
      for (std::size_t a = 0; a < sc.agents.size(); ++a) {
        const PlanarPose p = sc.agents[a].pose(tt);
        top.agent_paths[a].emplace_back(p.x, p.y);
      }
    }
    for (const auto& s : sites) top.infra.push_back(s.sensor_to_enu.translation().head<2>());
    top.agents_have_lidar = agents;
    if (!write_top_view((root / "topview.png").string(), sim.iw, top, err)) {
      error = err;
      return false;
    }
  }
  summary.bytes = folder_bytes(root);
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return true;
}

}  // namespace v2xloc::sim
