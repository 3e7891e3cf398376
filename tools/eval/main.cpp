// v2xloc-eval RECORDING_DIR... [--json] [--plots DIR] [--estimates DIR] [--trace DIR] [--frames N]
//   [--gate fixed-lag|causal|off] [--no-gnss-gate] [--no-odometry] [--no-vehicle] [--no-gnss-heading]
//   [--stereo] [--quiet] [--timing] [--callgrind-dumps] [--firmware PATH [--faults SPEC]]
// Runs the localizer offline over each recording and prints the paper's Table 1 (unaligned and
// aligned) with the paper's numbers beside ours; --json prints one JSON object instead.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "host_sim/eval/trajectory.hpp"
#include "tools/eval/firmware_run.hpp"
#include "tools/eval/metrics.hpp"
#include "tools/eval/offline_run.hpp"
#include "tools/eval/plots.hpp"
#include "tools/eval/report.hpp"

namespace {

v2xloc::Localizer g_localizer;  // hundreds of MB of static buffers: never on the stack

bool write_estimates(const std::string& dir, const std::string& name,
                     const std::vector<v2xloc::eval::FrameRecord>& records, std::string& error) {
  v2xloc::sim::StampedTrajectory fused, truth;
  for (const auto& r : records) {
    v2xloc::sim::StampedPose p;
    p.t = r.t;
    const Eigen::Isometry3d f(r.out.fused_pose);
    p.position = f.translation();
    p.orientation = Eigen::Quaterniond(f.linear());
    fused.push_back(p);
    p.position = r.truth.translation();
    p.orientation = Eigen::Quaterniond(r.truth.linear());
    truth.push_back(p);
  }
  return v2xloc::sim::write_tum(dir + "/" + name + "_fused.tum", fused, error);
}

// One line per frame: what the localizer did and how far each output is from the truth (debugging
// and the closing notes' per-frame analyses).
bool write_trace(const std::string& path, const std::vector<v2xloc::eval::FrameRecord>& records, std::string& error) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    error = "cannot write " + path;
    return false;
  }
  std::fprintf(f, "# frame t mode attempted status fitness rmse fused gate_decided gate_valid err_fused_xy "
                  "err_reg_xy err_ungated_xy err_fused_yaw_deg sigma_xy initialized odom_ok odom_step_err odom_step_yaw_err_deg err_stereo_xy stereo_fused "
                  "searched heading_used best_tight runner_up_tight err_search_best_xy err_search_runner_up_xy "
                  "err_fused_3d err_lag_3d revised best_conflicts runner_up_conflicts\n");
  for (std::size_t i = 0; i < records.size(); ++i) {
    const auto& r = records[i];
    // Odometry's frame-to-frame motion against the truth's (drift per step).
    double step_err = 0.0, step_yaw_err = 0.0;
    if (i > 0) {
      const Eigen::Isometry3d odo = Eigen::Isometry3d(records[i - 1].out.odometry_pose).inverse() *
                                    Eigen::Isometry3d(r.out.odometry_pose);
      const Eigen::Isometry3d tru = records[i - 1].truth.inverse() * r.truth;
      const Eigen::Isometry3d e = tru.inverse() * odo;
      step_err = e.translation().norm();
      step_yaw_err = std::atan2(e.linear()(1, 0), e.linear()(0, 0)) * 180.0 / M_PI;
    }
    const auto& o = r.out;
    const Eigen::Vector3d truth = r.truth.translation();
    auto err_xy = [&](const v2xloc::Pose3d& T) { return (T.translation().head<2>() - truth.head<2>()).norm(); };
    const Eigen::Matrix3d dr = r.truth.linear().transpose() * o.fused_pose.linear();
    const double yaw_err = std::atan2(dr(1, 0), dr(0, 0)) * 180.0 / M_PI;
    std::fprintf(f, "%u %.3f %d %d %d %.4f %.4f %d %d %d %.4f %.4f %.4f %.3f %.4f %d %d %.4f %.3f %.4f %d %d %d %.4f %.4f %.3f %.3f %.4f %.4f %d %.3f %.3f\n",
                 o.frame, r.t,
                 static_cast<int>(o.mode), o.registration_attempted ? 1 : 0, static_cast<int>(o.registration_status),
                 o.fitness, o.inlier_rmse, o.registration_fused ? 1 : 0, r.gate_decided ? 1 : 0, r.gate_valid ? 1 : 0,
                 err_xy(o.fused_pose), o.registration_attempted ? err_xy(o.registration_pose) : -1.0,
                 err_xy(o.fused_pose_ungated), yaw_err, std::sqrt(0.5 * (o.sigma_x * o.sigma_x + o.sigma_y * o.sigma_y)),
                 o.filter_initialized ? 1 : 0, o.odometry_ok ? 1 : 0, step_err, step_yaw_err,
                 o.stereo_attempted ? err_xy(o.stereo_pose) : -1.0, o.stereo_fused ? 1 : 0, o.searched ? 1 : 0,
                 o.search_heading_used ? 1 : 0, o.search_best_tight, o.search_runner_up_tight,
                 o.searched ? err_xy(o.search_best_pose) : -1.0,
                 o.searched && o.search_runner_up_tight > 0.0 ? err_xy(o.search_runner_up_pose) : -1.0,
                 (o.fused_pose.translation() - truth).norm(),
                 (r.lagged_pose.topRightCorner<3, 1>() - truth).norm(), r.revised ? 1 : 0,
                 o.search_best_conflicts, o.search_runner_up_conflicts);
  }
  std::fclose(f);
  return true;
}

// Everything the command line sets; parse_args returns -1 to run, else the exit code (0 for --help,
// 2 for a usage error, with CLI11's message).
struct EvalArgs {
  std::vector<std::string> dirs;
  bool json = false;
  std::string plots_dir, estimates_dir, trace_dir;
  std::string firmware_path;              // --firmware: table from the firmware's CAN output
  v2xloc::sim::replay::FaultSpec faults;  // --faults SPEC (with --firmware)
  bool faults_given = false;              // --faults, even "none": the counts are reported
  v2xloc::eval::RunOptions options;
};

int parse_args(int argc, char** argv, EvalArgs& a) {
  CLI::App app{"Runs the localizer over recordings and prints the paper's Table 1 (unaligned and aligned) with\n"
               "the paper's numbers beside ours; --json prints one JSON object instead.",
               "v2xloc-eval"};
  v2xloc::LocalizerParams& params = a.options.params;
  app.add_option("RECORDING_DIR", a.dirs, "recording folders (v2xloc-sim generate)")->required()->type_name("DIR");
  app.add_flag("--json", a.json, "one JSON object on stdout instead of the tables (implies --quiet)");
  app.add_option("--plots", a.plots_dir, "write plot data and draw the plots (matplotlib) into DIR")->type_name("DIR");
  app.add_option("--estimates", a.estimates_dir, "write the fused trajectories (TUM) into DIR")->type_name("DIR");
  app.add_option("--trace", a.trace_dir, "write a per-frame trace per recording into DIR")->type_name("DIR");
  app.add_option("--frames", a.options.max_frames, "evaluate the first N frames only")
      ->type_name("N")
      ->check(CLI::Range(1, v2xloc::sim::RecordingReader::kMaxFrames));
  std::string gate;
  app.add_option("--gate", gate, "validity gate: fixed-lag (default), causal or off")
      ->type_name("MODE")
      ->check(CLI::IsMember({"fixed-lag", "causal", "off"}));
  app.add_flag("--no-gnss-gate", [&params](std::int64_t) { params.filter.ekf.gates.gnss_gate_enabled = false; },
               "ablation: fuse every GNSS fix (no chi-square gate)");
  app.add_flag("--no-odometry", [&params](std::int64_t) { params.filter.use_odometry = false; }, "ablation: no LiDAR odometry");
  app.add_flag("--no-vehicle", [&params](std::int64_t) { params.use_vehicle_signals = false; },
               "ablation: no wheel speed / yaw rate");
  app.add_flag("--no-gnss-heading", [&params](std::int64_t) { params.course.enabled = false; },
               "ablation: no course over ground from the GNSS Doppler velocity");
  app.add_flag("--stereo", params.use_stereo, "also register the stereo clouds (recordings with disparity maps)");
  app.add_flag("--quiet", a.options.quiet, "no per-frame progress on stderr");
  app.add_flag("--timing", a.options.timing, "host ms per 100 ms period and stage (table and JSON \"timing\")");
  app.add_flag("--callgrind-dumps", a.options.callgrind_dumps,
               "under callgrind: a stats dump per stage of each period (tools/timing/frame_instructions.py)");
  auto* firmware = app.add_option("--firmware", a.firmware_path,
                                  "replay through this v2xloc-firmware over emulated CAN/UDP instead of the in-process "
                                  "localizer (localizer options other than --frames do not apply)")
                      ->type_name("PATH");
  std::string fault_text;
  app.add_option("--faults", fault_text, "fault injection on the replay, e.g. loss=0.3,reorder=0.2 (host_sim/replay)")
      ->type_name("SPEC")
      ->needs(firmware);
  try {
    app.parse(argc, argv);
    std::string error;
    if (!fault_text.empty() && !v2xloc::sim::replay::parse_fault_spec(fault_text, a.faults, error))
      throw CLI::ValidationError("--faults", error);
    a.faults_given = !fault_text.empty();
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (gate == "fixed-lag") params.filter.gate_mode = v2xloc::GateMode::kFixedLag;
  if (gate == "causal") params.filter.gate_mode = v2xloc::GateMode::kCausal;
  if (gate == "off") params.filter.gate_mode = v2xloc::GateMode::kOff;
  if (a.json) a.options.quiet = true;
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  EvalArgs args;
  if (const int rc = parse_args(argc, argv, args); rc >= 0) return rc;
  const std::vector<std::string>& dirs = args.dirs;
  const bool json = args.json;
  const std::string &plots_dir = args.plots_dir, &estimates_dir = args.estimates_dir, &trace_dir = args.trace_dir;
  const std::string& firmware_path = args.firmware_path;
  const v2xloc::sim::replay::FaultSpec& faults = args.faults;
  const v2xloc::eval::RunOptions& common_options = args.options;

  std::vector<v2xloc::eval::RowReport> rows;
  for (const std::string& dir : dirs) {
    v2xloc::sim::RecordingReader reader;
    std::string error;
    if (!reader.open(dir, error)) {
      std::fprintf(stderr, "v2xloc-eval: %s: %s\n", dir.c_str(), error.c_str());
      return 1;
    }
    v2xloc::eval::RunOptions options = common_options;
    reader.gnss_antenna_in_body(options.gnss_antenna_in_body);  // the recording's lever arm where it says
    v2xloc::eval::RowReport row;
    row.sim = reader.scenario();
    row.permutation = reader.permutation();
    row.dir = dir;
    if (!options.quiet) std::fprintf(stderr, "Sim %d %s (%s)\n", row.sim, row.permutation.c_str(), dir.c_str());
    std::vector<v2xloc::eval::FrameRecord> records;
    bool ran = false;
    if (!firmware_path.empty()) {
      v2xloc::eval::FirmwareRunOptions fw;
      fw.firmware_path = firmware_path;
      fw.max_frames = options.max_frames;
      fw.faults = faults;
      fw.report = args.faults_given;
      fw.gnss_antenna_in_body = options.gnss_antenna_in_body;
      fw.quiet = options.quiet;
      ran = v2xloc::eval::run_firmware(reader, fw, records, row.stats, error);
    } else {
      ran = v2xloc::eval::run_offline(reader, g_localizer, options, records, row.stats, error);
    }
    if (!ran) {
      std::fprintf(stderr, "v2xloc-eval: %s: %s\n", dir.c_str(), error.c_str());
      return 1;
    }
    const double map_from = reader.map_clouds().empty() ? 0.0 : reader.map_clouds().front().stamp;
    row.metrics = v2xloc::eval::compute_metrics(records, map_from);
    if (!firmware_path.empty()) v2xloc::eval::mark_columns_not_on_can(row.metrics);
    const std::string name = "sim" + std::to_string(row.sim) + "_" + row.permutation;
    if (!plots_dir.empty() && !v2xloc::eval::write_plot_data(plots_dir, name, reader, records, error)) {
      std::fprintf(stderr, "v2xloc-eval: plots: %s\n", error.c_str());
      return 1;
    }
    if (!estimates_dir.empty()) {
      std::filesystem::create_directories(estimates_dir);
      if (!write_estimates(estimates_dir, name, records, error)) {
        std::fprintf(stderr, "v2xloc-eval: estimates: %s\n", error.c_str());
        return 1;
      }
    }
    if (!trace_dir.empty()) {
      std::filesystem::create_directories(trace_dir);
      if (!write_trace(trace_dir + "/" + name + "_trace.txt", records, error)) {
        std::fprintf(stderr, "v2xloc-eval: trace: %s\n", error.c_str());
        return 1;
      }
    }
    rows.push_back(row);
  }
  if (!plots_dir.empty()) {  // matplotlib draws the pictures from the plot data (tools/plots/plot_run.py)
    const v2xloc::eval::PlotRender plots = v2xloc::eval::render_plots(plots_dir, trace_dir);
    if (!plots.ok) {
      std::fprintf(stderr, "v2xloc-eval: plots: %s\n", plots.message.c_str());
      if (!plots.skipped) return 1;
    }
  }
  if (json) {
    std::printf("%s\n", v2xloc::eval::format_json(rows).c_str());
  } else {
    std::printf("%s\n%s", v2xloc::eval::format_table(rows, false).c_str(),
                v2xloc::eval::format_table(rows, true).c_str());
    const std::string timing = v2xloc::eval::format_timing(rows);
    if (!timing.empty()) std::printf("\n%s", timing.c_str());
    if (!plots_dir.empty()) std::printf("\nplots: %s\n", plots_dir.c_str());
  }
  return 0;
}
