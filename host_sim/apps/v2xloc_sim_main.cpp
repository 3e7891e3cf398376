// v2xloc-sim generate --scenario 0..3 --perm 4_infra_2_agent|4_infra|2_infra --out DIR [--seed N]
//                     [--duration S] [--quick] [--no-stereo] [--no-imu] [--grade G --grade-heading DEG --crown C]
// v2xloc-sim generate --all --out DIR [--seed N] [--duration S] [--quick] [--no-stereo] [--no-imu]
// --all writes DIR/sim<k>_<perm>/ for all 12 combinations (one after the other; tools/run-demo.sh
// runs one process per recording instead, on every core).
// v2xloc-sim export-pcd RECORDING_DIR --out DIR [--encoding binary_compressed|binary|ascii]
// writes standard float32 PCD copies of a recording's clouds (the recording stores them quantised).
#include "host_sim/recording/pcd_export.hpp"
#include "host_sim/recording/recorder.hpp"

#include <cmath>
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <functional>
#include <memory>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using namespace v2xloc::sim;

// On a terminal one line is redrawn in place; in a log (stderr not a terminal, e.g. several
// generators in parallel) a line per quarter, so interleaved output stays readable.
std::function<void(int, int)> progress_printer(const std::string& tag, const std::string& name,
                                              const std::string& unit = "frames") {
  const bool tty = isatty(STDERR_FILENO) != 0;
  auto last = std::make_shared<int>(-1);
  return [tty, tag, name, unit, last](int done, int total) {
    const int pct = 100 * done / total;
    const int step = tty ? 5 : 25;
    if (pct / step == *last / step && done != total) return;
    *last = pct;
    if (tty) {
      std::fprintf(stderr, "\r%s %-22s %3d%% (%d/%d %s)", tag.c_str(), name.c_str(), pct, done, total, unit.c_str());
      if (done == total) std::fputc('\n', stderr);
    } else {
      std::fprintf(stderr, "%s %-22s %3d%% (%d/%d %s)\n", tag.c_str(), name.c_str(), pct, done, total, unit.c_str());
    }
    std::fflush(stderr);
  };
}

int run_export(const std::string& dir, const std::string& out, const std::string& encoding_name) {
  RecordingReader reader;
  std::string error;
  if (!reader.open(dir, error)) {
    std::fprintf(stderr, "v2xloc-sim export-pcd: %s\n", error.c_str());
    return 1;
  }
  const v2xloc::cloud_io::PcdEncoding encoding = encoding_name == "ascii"  ? v2xloc::cloud_io::PcdEncoding::kAscii
                                                 : encoding_name == "binary" ? v2xloc::cloud_io::PcdEncoding::kBinary
                                                                             : v2xloc::cloud_io::PcdEncoding::kBinaryCompressed;
  PcdExportSummary summary;
  if (!export_recording_pcd(reader, out, encoding, summary, error, progress_printer("[export]", dir, "clouds"))) {
    std::fprintf(stderr, "\nv2xloc-sim export-pcd: %s\n", error.c_str());
    return 1;
  }
  std::printf("exported %d clouds (%.1f MB, PCD %s) to %s\n", summary.clouds, static_cast<double>(summary.bytes) / 1e6,
              encoding_name.c_str(), out.c_str());
  return 0;
}

int run_generate(RecorderConfig base, bool all, int scenario, const std::string& perm_name, const std::string& out) {
  std::vector<RecorderConfig> jobs;
  if (all) {
    for (int s = 0; s < kScenarioCount; ++s)
      for (Permutation p : kAllPermutations) {
        RecorderConfig c = base;
        c.scenario = s;
        c.permutation = p;
        c.out_dir = out + "/" + recording_name(s, p);
        jobs.push_back(c);
      }
  } else {
    RecorderConfig c = base;
    c.scenario = scenario;
    parse_permutation(perm_name, c.permutation);  // checked by IsMember above
    c.out_dir = out;
    jobs.push_back(c);
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<RecordingSummary> summaries;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const std::string name = recording_name(jobs[j].scenario, jobs[j].permutation);
    const std::string tag = "[" + std::to_string(j + 1) + "/" + std::to_string(jobs.size()) + "]";
    RecordingSummary s;
    std::string error;
    if (!generate_recording(jobs[j], s, error, progress_printer(tag, name))) {
      std::fprintf(stderr, "\nerror: %s: %s\n", name.c_str(), error.c_str());
      return 1;
    }
    summaries.push_back(s);
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& s : summaries) std::printf("%s\n", s.one_line().c_str());
  if (summaries.size() > 1) std::printf("total: %zu recordings in %.1f s\n", summaries.size(), total);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Generates simulated recordings (scenarios Sim 0-3 x sensor permutations); see\n"
               "host_sim/RECORDING_FORMAT.md.",
               "v2xloc-sim"};
  app.require_subcommand(1);
  CLI::App* generate = app.add_subcommand("generate", "render one recording (--scenario, --perm) or all 12 (--all)");
  RecorderConfig base;
  int scenario = -1;
  std::string perm_name;
  bool all = false;
  bool no_stereo = false;
  std::string out;
  std::vector<std::string> perm_names;
  for (Permutation p : kAllPermutations) perm_names.push_back(permutation_name(p));
  auto* scenario_opt = generate->add_option("--scenario", scenario, "scenario Sim 0..3")
                           ->check(CLI::Range(0, kScenarioCount - 1));
  auto* perm_opt = generate->add_option("--perm", perm_name, "sensor permutation")->check(CLI::IsMember(perm_names));
  auto* all_flag = generate->add_flag("--all", all, "all 12 recordings, as OUT/sim<k>_<perm>/");
  all_flag->excludes(scenario_opt)->excludes(perm_opt);
  generate->add_option("--out", out, "recording folder (with --all: the parent folder)")->required();
  generate->add_option("--seed", base.seed, "noise seed (same seed, same bytes)");
  generate->add_option("--duration", base.duration, "seconds (default: the scenario's own; --quick: 3 s)")
      ->check(CLI::NonNegativeNumber);
  generate->add_flag("--quick", base.quick, "CI configuration: few beams / azimuth steps, coarse stereo");
  generate->add_flag("--no-stereo", no_stereo, "no disparity maps");
  bool no_imu = false;
  generate->add_flag("--no-imu", no_imu, "no IMU reports (imu_reports.txt)");
  double grade_heading_deg = 0.0;
  generate->add_option("--grade", base.terrain.grade, "site-wide slope, rise/run (e.g. 0.05)")
      ->check(CLI::Range(-0.15, 0.15));
  generate->add_option("--grade-heading", grade_heading_deg, "direction of steepest ascent, deg from east")
      ->check(CLI::Range(-360.0, 360.0));
  generate->add_option("--crown", base.terrain.crown, "road cross slope from the axis to the curb, rise/run (e.g. 0.02)")
      ->check(CLI::Range(0.0, 0.08));
  CLI::App* export_pcd = app.add_subcommand(
      "export-pcd", "standard PCD copies of a recording's clouds (float32 x y z intensity t) for PCL / Open3D");
  std::string export_in, export_out, encoding_name = "binary_compressed";
  export_pcd->add_option("RECORDING_DIR", export_in, "recording folder")->required();
  export_pcd->add_option("--out", export_out, "output folder: ego_lidar/, infra/, agents/ as in the recording")
      ->required();
  export_pcd->add_option("--encoding", encoding_name, "PCD DATA kind (binary_compressed: LZF, as PCL writes it)")
      ->check(CLI::IsMember({"binary_compressed", "binary", "ascii"}));
  try {
    app.parse(argc, argv);
    if (generate->parsed() && !all && (scenario < 0 || perm_name.empty()))
      throw CLI::ValidationError("generate", "needs --scenario and --perm, or --all");
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // usage errors keep exit code 2
  }
  if (export_pcd->parsed()) return run_export(export_in, export_out, encoding_name);
  base.stereo = !no_stereo;
  base.imu = !no_imu;
  base.terrain.grade_heading = grade_heading_deg * M_PI / 180.0;
  return run_generate(base, all, scenario, perm_name, out);
}
