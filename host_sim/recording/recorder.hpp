// Renders one (scenario, permutation) into a recording folder; see host_sim/RECORDING_FORMAT.md.
#pragma once

#include "host_sim/scenario/scenario.hpp"

#include <cstdint>
#include <functional>
#include <string>

namespace v2xloc::sim {

struct RecorderConfig {
  int scenario = 0;
  Permutation permutation = Permutation::k4Infra2Agent;
  std::uint64_t seed = 1;
  double duration = 0.0;       // s; <= 0: scenario default (quick: 3 s)
  bool quick = false;          // CI configuration: few beams / azimuth steps, coarse stereo
  std::string out_dir;         // the recording folder (created)
  double map_rate_hz = 2.0;    // infrastructure + agent cloud rate (every 5th ego frame)
  bool stereo = true;
  double gnss_rate_hz = 5.0;
  double vehicle_rate_hz = 100.0;
  bool imu = true;             // the ego IMU's HID reports (imu_reports.txt, host_sim/sensors/imu.hpp)
  Terrain terrain;             // sloped streets (grade, crown); flat by default
  // Geodetic origin of the local ENU frame (the intersection centre).
  double origin_lat_deg = 48.1374, origin_lon_deg = 11.5755, origin_alt_m = 520.0;
  double time_origin_unix_s = 1700000000.0;  // CAN log timestamps = this + recording time
  // Agent self-localization error in the reported agent cloud poses: a per-run bias plus
  // per-cloud white noise (horizontal position per axis, yaw).
  double agent_pos_bias_sigma = 0.05, agent_pos_noise_sigma = 0.02;        // m
  double agent_yaw_bias_sigma_deg = 0.2, agent_yaw_noise_sigma_deg = 0.05;  // deg
};

struct RecordingSummary {
  std::string name;            // e.g. sim0_4_infra_2_agent
  int frames = 0;
  double points_per_scan_mean = 0, points_per_scan_min = 0, points_per_scan_max = 0;
  int map_clouds = 0;
  int gnss_fixes = 0;
  double gnss_mean_h_error = 0, gnss_max_h_error = 0, hdop_min = 0, hdop_max = 0;
  std::uint64_t bytes = 0;
  double seconds = 0;          // wall time
  std::string one_line() const;
};

// progress(done, total) is called after each ego frame.
bool generate_recording(const RecorderConfig& cfg, RecordingSummary& summary, std::string& error,
                        const std::function<void(int, int)>& progress = {});

std::string recording_name(int scenario, Permutation p);  // "sim0_4_infra_2_agent"

}  // namespace v2xloc::sim
