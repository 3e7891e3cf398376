// v2xloc-replay RECORDING_DIR [--firmware PATH | --connect HOST:CANPORT,CLOUDPORT [--local-can-port N]]
//               [--out DIR] [--frames N] [--timeout S] [--verbose] [-- FIRMWARE_ARGS...]
// Starts v2xloc-firmware --emulated (default: next to this executable) or connects to a running
// one, replays the recording in lockstep, writes DIR/fused.tum, evaluates against the ground truth
// (APE unaligned and SE(3)-aligned) and prints a summary. Exit code 0 only on a complete replay.
#include <unistd.h>

#include <climits>
#include <cstdio>
#include <filesystem>
#include <string>

#include "host_sim/replay/replay_session.hpp"

#include <CLI/CLI.hpp>

namespace {

using namespace v2xloc::sim;
using namespace v2xloc::sim::replay;

std::string default_firmware_path() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return "v2xloc-firmware";
  buf[n] = '\0';
  return (std::filesystem::path(buf).parent_path() / "v2xloc-firmware").string();
}

void print_ape(const char* label, const ErrorStats& s) {
  std::printf("  %-22s n %4zu  mean %8.3f m  rmse %8.3f m  median %8.3f m  max %8.3f m\n", label, s.count, s.mean,
              s.rmse, s.median, s.max);
}

// The command line: everything after "--" goes to the firmware untouched (split off before CLI11
// sees it); --connect HOST:CANPORT,CLOUDPORT names a running firmware instead of starting one.
struct Command {
  ReplayOptions options;
  std::string dir, out_dir;
  bool connect = false;
};

// Parses argv into `cmd`; returns -1 to go on, otherwise the exit code (help: 0, usage errors: 2).
int parse_command_line(int argc, char** argv, Command& cmd) {
  int own_argc = argc;
  ReplayOptions& options = cmd.options;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--") {
      own_argc = i;
      for (int k = i + 1; k < argc; ++k) options.firmware_args.emplace_back(argv[k]);
      break;
    }
  }
  CLI::App app{"Replays a recording in lockstep into v2xloc-firmware (started with --emulated, or a running one\n"
               "with --connect), writes OUT/fused.tum and prints the APE against the ground truth. Exit 0 only\n"
               "on a complete replay. Arguments after -- go to the firmware.",
               "v2xloc-replay"};
  std::string connect_spec, faults_spec;
  app.add_option("RECORDING_DIR", cmd.dir, "recording folder (v2xloc-sim generate)")->required();
  auto* firmware_opt = app.add_option("--firmware", options.firmware_path,
                                      "v2xloc-firmware to start (default: next to this executable)");
  auto* connect_opt = app.add_option("--connect", connect_spec, "HOST:CANPORT,CLOUDPORT of a running firmware")
                          ->excludes(firmware_opt);
  app.add_option("--local-can-port", options.local_can_port, "our CAN UDP port with --connect");
  app.add_option("--out", cmd.out_dir, "folder for fused.tum");
  app.add_option("--frames", options.stream.max_frames, "replay only the first N frames");
  app.add_option("--timeout", options.frame_timeout_s, "seconds to wait for each frame's output");
  app.add_flag("--verbose", options.verbose, "print every exchange");
  app.add_option("--faults", faults_spec,
                 "fault injection, comma-separated key=value (e.g. loss=0.3,delay=0.5,rogue-shift=3; keys in "
                 "host_sim/replay/fault_injection.hpp)");
  try {
    app.parse(own_argc, argv);
    if (connect_opt->count() > 0) {
      unsigned can = 0, cloud = 0;
      char host[64] = {};
      if (std::sscanf(connect_spec.c_str(), "%63[^:]:%u,%u", host, &can, &cloud) != 3 || can > 65535 || cloud > 65535)
        throw CLI::ValidationError("--connect", "expected HOST:CANPORT,CLOUDPORT, got '" + connect_spec + "'");
      options.host = host;
      options.firmware_can_port = static_cast<std::uint16_t>(can);
      options.firmware_cloud_port = static_cast<std::uint16_t>(cloud);
      cmd.connect = true;
    }
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // usage errors keep exit code 2
  }
  if (std::string ferr; !faults_spec.empty() && !parse_fault_spec(faults_spec, options.stream.faults, ferr)) {
    std::fprintf(stderr, "v2xloc-replay: --faults: %s\n", ferr.c_str());
    return 2;
  }
  if (!cmd.connect && options.firmware_path.empty()) options.firmware_path = default_firmware_path();
  return -1;
}

// What was sent and received: the event stream's and the fault injection's counters, the CAN
// receive side's.
void print_counters(const ReplayOptions& options, const ReplayResult& result) {
  const EventStreamStats& s = result.stream_stats;
  std::printf("v2xloc-replay: %zu frames replayed in %.2f s (%.1f frames/s); sent %zu CAN frames, %zu datagrams "
              "(%zu map clouds, %zu ego scans, %llu points dropped by quantization range, %llu point times clamped)\n",
              result.frames.size(), result.wall_seconds,
              result.wall_seconds > 0 ? result.frames.size() / result.wall_seconds : 0.0, result.can_frames_sent,
              result.datagrams_sent, s.map_clouds, s.ego_scans, (unsigned long long)s.points_dropped,
              (unsigned long long)s.times_clamped);
  const FaultStats& fs = result.stream_stats.faults;
  std::printf("v2xloc-replay: faults %s: shares lost %llu, datagrams dropped %llu reordered %llu duplicated %llu, "
              "shares delayed %llu, GNSS frames dropped %llu, infra shares dropped %llu, corrupt CAN %llu, rogue shares "
              "%llu, ego time jumps %llu, ego scans blinded %llu (frames without a scan %d, periods closed without a scan %d, "
              "late scans %d, frames without a pose %d)\n",
              describe(options.stream.faults).c_str(), (unsigned long long)fs.shares_lost,
              (unsigned long long)fs.datagrams_dropped, (unsigned long long)fs.datagrams_reordered,
              (unsigned long long)fs.datagrams_duplicated, (unsigned long long)fs.shares_delayed,
              (unsigned long long)fs.gnss_frames_dropped, (unsigned long long)fs.infra_shares_dropped,
              (unsigned long long)fs.can_corrupt_sent, (unsigned long long)fs.rogue_shares,
              (unsigned long long)fs.ego_time_jumps, (unsigned long long)fs.ego_scans_blinded,
              result.frames_without_scan, result.periods_without_scan, result.late_scans, result.frames_without_pose);
  std::printf("v2xloc-replay: IMU reports %zu; faults: dropped %llu stuck %llu biased %llu repeated %llu reordered %llu\n",
              s.imu_reports, (unsigned long long)fs.imu.dropped, (unsigned long long)fs.imu.stuck,
              (unsigned long long)fs.imu.biased, (unsigned long long)fs.imu.repeated, (unsigned long long)fs.imu.reordered);
  std::printf("v2xloc-replay: heartbeats %zu, pose decode errors %zu, diagnostic decode errors %zu, timeouts %d, "
              "send retries %zu\n",
              result.heartbeats, result.pose_decode_errors, result.diagnostic_decode_errors, result.timeouts,
              result.send_retries);
}

// OUT/fused.tum (when asked) and the APE of the fused pose against the ground truth.
bool report_trajectory(const RecordingReader& reader, const Command& cmd, const ReplayResult& result) {
  const StampedTrajectory estimate = pose_frames_to_trajectory(result.frames);
  if (!cmd.out_dir.empty()) {
    std::filesystem::create_directories(cmd.out_dir);
    std::string werr;
    if (!write_tum(cmd.out_dir + "/fused.tum", estimate, werr)) {
      std::fprintf(stderr, "v2xloc-replay: %s\n", werr.c_str());
      return false;
    }
    std::printf("v2xloc-replay: wrote %s/fused.tum\n", cmd.out_dir.c_str());
  }
  if (estimate.size() >= 3) {
    const StampedTrajectory truth = ground_truth_trajectory(reader);
    std::size_t valid = 0;
    for (const auto& f : result.frames) valid += f.position.flags.pose_valid ? 1 : 0;
    std::printf("v2xloc-replay: APE of the fused pose (CAN, 1 mm / 1e-4 rad resolution), %zu/%zu frames valid:\n",
                valid, result.frames.size());
    print_ape("unaligned", absolute_position_error(estimate, truth, false));
    print_ape("aligned (SE(3))", absolute_position_error(estimate, truth, true));
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Command cmd;
  if (const int rc = parse_command_line(argc, argv, cmd); rc >= 0) return rc;
  RecordingReader reader;
  std::string error;
  if (!reader.open(cmd.dir, error)) {
    std::fprintf(stderr, "v2xloc-replay: %s\n", error.c_str());
    return 1;
  }
  std::printf("v2xloc-replay: %s (scenario %d, %s, %d frames)%s\n", cmd.dir.c_str(), reader.scenario(),
              reader.permutation().c_str(), reader.frame_count(),
              cmd.connect ? " -> connected firmware" : (" -> " + cmd.options.firmware_path).c_str());
  ReplayResult result;
  const bool ok = replay_recording(reader, cmd.options, result, error);
  if (!result.firmware_output.empty()) {
    std::printf("---- firmware output ----\n%s-------------------------\n", result.firmware_output.c_str());
  }
  print_counters(cmd.options, result);
  if (!report_trajectory(reader, cmd, result)) return 1;
  if (!ok) {
    std::fprintf(stderr, "v2xloc-replay: FAILED: %s\n", error.c_str());
    return 1;
  }
  return 0;
}
