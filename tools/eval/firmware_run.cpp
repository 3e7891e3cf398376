#include "tools/eval/firmware_run.hpp"

#include <cmath>
#include <cstdio>

#include "firmware/protocol/can_messages.hpp"
#include "tools/eval/gnss_track.hpp"
#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::eval {
namespace {

// world_T_body (or odom_T_body) from what the DBC carries: position and heading; roll = pitch = 0.
Mat4d pose_from_xyz_yaw(double x, double y, double z, double yaw) {
  Mat4d T = Mat4d::Identity();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.topLeftCorner<3, 3>() = R;
  T(0, 3) = x;
  T(1, 3) = y;
  T(2, 3) = z;
  return T;
}

// Frame index of a 16-bit counter that is at most 65535 frames older than `now`.
std::uint32_t unwrap_counter(std::uint16_t counter, std::uint32_t now) {
  const auto back = static_cast<std::uint16_t>(static_cast<std::uint16_t>(now & 0xFFFFu) - counter);
  return back <= now ? now - back : 0u;
}

LocalizationMode mode_from_code(protocol::LocalizerModeCode code) {
  switch (code) {
    case protocol::LocalizerModeCode::kGlobalSearch: return LocalizationMode::kGlobalSearch;
    case protocol::LocalizerModeCode::kTracking: return LocalizationMode::kTracking;
    case protocol::LocalizerModeCode::kUninitialized: break;
  }
  return LocalizationMode::kUninitialized;
}

}  // namespace

LocalizerFrameOutput output_from_can(const sim::replay::ReplayedFrame& f, std::uint32_t frame_index) {
  LocalizerFrameOutput out;
  out.frame = frame_index;
  out.t = f.t;
  // Fused pose, sigmas and flags (0x200..0x202).
  out.fused_pose = pose_from_xyz_yaw(f.position.x_m, f.position.y_m, f.attitude.z_m, f.attitude.yaw_rad);
  out.fused_pose_ungated = out.fused_pose;  // the shadow filter is not on the wire
  out.sigma_x = f.sigma.sigma_x_m;
  out.sigma_y = f.sigma.sigma_y_m;
  out.sigma_z = f.sigma.sigma_z_m;
  out.sigma_yaw = f.sigma.sigma_yaw_rad;
  out.localized = f.position.flags.pose_valid;
  out.registration_fused = f.position.flags.registration_valid;
  // Registration (0x210, 0x211): position only; a failure's exact status is not carried.
  out.registration_attempted = f.registration_position.attempted;
  if (f.registration_position.ok) out.registration_status = RegistrationStatus::kOk;
  else if (f.registration_position.attempted) out.registration_status = RegistrationStatus::kDidNotConverge;
  // (not attempted: the output's default status, as the localizer leaves it)
  out.registration_pose = pose_from_xyz_yaw(f.registration_position.x_m, f.registration_position.y_m,
                                            f.registration_quality.z_m, 0.0);
  out.fitness = f.registration_quality.fitness;
  out.inlier_rmse = f.registration_quality.inlier_rmse_m;
  // Gate decision and localizer state (0x212).
  out.mode = mode_from_code(f.gate.mode);
  out.filter_initialized = f.gate.filter_initialized;
  out.gate_decided = f.gate.decided;
  out.gate_decided_valid = f.gate.decided && f.gate.valid;
  out.gate_decided_frame = f.gate.decided ? unwrap_counter(f.gate.decided_frame, frame_index) : 0u;
  // Odometry (0x213, 0x214).
  out.odometry_ok = f.odometry_position.odometry_ok;
  out.odometry_pose = pose_from_xyz_yaw(f.odometry_position.x_m, f.odometry_position.y_m, f.odometry_attitude.z_m,
                                        f.odometry_attitude.yaw_rad);
  return out;
}

bool records_from_outputs(const sim::RecordingReader& reader, const std::vector<LocalizerFrameOutput>& outputs,
                          const Eigen::Vector3d& gnss_antenna_in_body, std::vector<FrameRecord>& records,
                          std::string& error, const std::vector<int>& recording_frames) {
  if (!recording_frames.empty() && recording_frames.size() != outputs.size()) {
    error = "one recording frame per output expected";
    return false;
  }
  records.assign(outputs.size(), FrameRecord{});
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const int frame = recording_frames.empty() ? static_cast<int>(i) : recording_frames[i];
    if (frame < 0 || static_cast<std::size_t>(frame) >= reader.ground_truth().size()) {
      error = "frame " + std::to_string(frame) + " has no ground-truth pose";
      return false;
    }
    FrameRecord& rec = records[i];
    rec.t = reader.frame_time(frame);
    rec.truth = reader.ground_truth()[static_cast<std::size_t>(frame)].pose;
    rec.out = outputs[i];
    rec.lagged_pose = rec.out.fused_pose.matrix();
  }
  if (!fill_gnss(reader, gnss_antenna_in_body, records, error)) return false;
  // Revisions are not on the wire, but everything they need is (fused pose, FilterInitialized,
  // odometry pose and OdometryOk): a receiver revises the start-up frames itself, with the
  // localizer's own algorithm, on the quantized values (1 mm, 1e-4 rad).
  TrajectoryBackfill backfill;
  for (std::size_t i = 0; i < records.size(); ++i) {
    BackfillSample sample;
    sample.frame = records[i].out.frame;
    sample.odom_T_body = records[i].out.odometry_pose.matrix();
    sample.world_T_body = records[i].out.fused_pose.matrix();
    sample.anchored = records[i].out.filter_initialized;
    sample.odometry_ok = records[i].out.odometry_ok;
    backfill.push(sample);
    take_revisions(backfill, i, records);
  }
  // A fixed-lag decision published at frame i is about an earlier frame.
  for (const FrameRecord& rec : records) {
    if (rec.out.gate_decided && rec.out.gate_decided_frame < records.size()) {
      records[rec.out.gate_decided_frame].gate_decided = true;
      records[rec.out.gate_decided_frame].gate_valid = rec.out.gate_decided_valid;
    }
  }
  return true;
}

bool run_firmware(const sim::RecordingReader& reader, const FirmwareRunOptions& options,
                  std::vector<FrameRecord>& records, RunStats& stats, std::string& error) {
  stats = {};
  sim::replay::ReplayOptions replay;
  replay.firmware_path = options.firmware_path;
  replay.frame_timeout_s = options.frame_timeout_s;
  replay.stream.max_frames = options.max_frames;
  replay.stream.faults = options.faults;
  const int total = options.max_frames < 0 ? reader.frame_count() : std::min(options.max_frames, reader.frame_count());
  if (!options.quiet) {
    replay.on_frame = [&](const sim::replay::ReplayedFrame& f) {
      std::fprintf(stderr, "\r  firmware frame %4d/%d  x %9.3f y %9.3f  reg %d%d fit %.3f  ", f.frame + 1, total,
                   f.position.x_m, f.position.y_m, f.registration_position.attempted ? 1 : 0,
                   f.registration_position.ok ? 1 : 0, f.registration_quality.fitness);
    };
  }
  sim::replay::ReplayResult result;
  if (!sim::replay::replay_recording(reader, replay, result, error)) {
    if (!result.firmware_output.empty()) error += "\nfirmware output:\n" + result.firmware_output;
    return false;
  }
  // Output i is the firmware's period i (its frame counters count periods, with or without a scan:
  // a frame whose scan was never sent gets the period the firmware's timer closes at its stamp).
  std::vector<LocalizerFrameOutput> outputs;
  std::vector<int> recording_frames;
  outputs.reserve(result.frames.size());
  for (std::size_t i = 0; i < result.frames.size(); ++i) {
    outputs.push_back(output_from_can(result.frames[i], static_cast<std::uint32_t>(i)));
    recording_frames.push_back(result.frames[i].frame);
  }
  if (!records_from_outputs(reader, outputs, options.gnss_antenna_in_body, records, error, recording_frames)) return false;
  stats.frames_without_pose = result.frames_without_pose;
  stats.seconds = result.wall_seconds;
  stats.can_decode_errors = result.pose_decode_errors + result.diagnostic_decode_errors;
  stats.map_clouds = result.stream_stats.map_clouds;
  if (!options.quiet) {
    std::fprintf(stderr,
                 "\n  firmware replay: %zu frames in %.1f s, %zu CAN frames + %zu datagrams sent, %zu heartbeats, "
                 "decode errors %zu, firmware exit %d\n",
                 result.frames.size(), result.wall_seconds, result.can_frames_sent, result.datagrams_sent,
                 result.heartbeats, stats.can_decode_errors, result.firmware_exit_code);
  }
  if (options.faults.any() || options.report || !options.quiet) {
    // The firmware's own account of what it refused (trust, channel, time, CAN) and the injector's.
    const sim::replay::FaultStats& f = result.stream_stats.faults;
    std::fprintf(stderr, "  faults %s: shares lost %llu, datagrams dropped %llu reordered %llu duplicated %llu, delayed %llu,"
                 " GNSS frames dropped %llu, infra shares dropped %llu, corrupt CAN %llu, rogue shares %llu, ego time jumps %llu,"
                 " ego scans blinded %llu (frames without a scan %d, without a pose %d)\n",
                 sim::replay::describe(options.faults).c_str(), (unsigned long long)f.shares_lost,
                 (unsigned long long)f.datagrams_dropped, (unsigned long long)f.datagrams_reordered,
                 (unsigned long long)f.datagrams_duplicated, (unsigned long long)f.shares_delayed,
                 (unsigned long long)f.gnss_frames_dropped, (unsigned long long)f.infra_shares_dropped,
                 (unsigned long long)f.can_corrupt_sent, (unsigned long long)f.rogue_shares,
                 (unsigned long long)f.ego_time_jumps, (unsigned long long)f.ego_scans_blinded,
                 result.frames_without_scan, result.frames_without_pose);
    std::size_t pos = 0;
    while (pos < result.firmware_output.size()) {
      const std::size_t end = result.firmware_output.find('\n', pos);
      const std::string line = result.firmware_output.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
      if (line.find("trust shares") != std::string::npos || line.find("trust list") != std::string::npos || line.find("decoded vehicle") != std::string::npos ||
          line.find("map fusion") != std::string::npos || line.find("reassembly") != std::string::npos ||
          line.find("localizer searches") != std::string::npos) {
        std::fprintf(stderr, "  %s\n", line.c_str());
      }
      if (end == std::string::npos) break;
      pos = end + 1;
    }
  }
  return true;
}

void mark_columns_not_on_can(RowMetrics& metrics) {
  metrics.unaligned.fused_ungated = -1.0;
  metrics.aligned.fused_ungated = -1.0;
  metrics.offset.has_yaw = false;  // 0x210 carries the registration's position only
}

}  // namespace v2xloc::eval
