// v2xloc-dataset: the core on public dataset layouts.
//   v2xloc-dataset kitti SEQ_DIR [--out POSES_TXT] [--poses GT_TXT] [--voxel M] [--json]
//   v2xloc-dataset dair-v2x-c ROOT [--mode global|search|icp] [--prior none|gnss] [--voxel M]
//                                  [--seed N] [--limit N] [--json]
// Layouts: tools/dataset/kitti_sequence.hpp and tools/dataset/dair_v2x.hpp.
//   v2xloc-dataset dair-v2x-c ROOT --recording OUT [--batch ID]: the sequence as a v2xloc recording
// Exit 0 done, 1 the run worked but a pair's verdict is not ok (dair; when none is ok, stderr says
// why), 2 usage / unusable input.
#include "tools/dataset/dair_recording.hpp"
#include "tools/dataset/dair_v2x.hpp"
#include "tools/dataset/kitti_run.hpp"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <cstdio>
#include <string>

namespace {

using namespace v2xloc::dataset;

struct KittiCommand {
  KittiRunOptions options;
  double voxel = options.odometry.voxel_size;
  std::string out, poses;
};

struct DairCommand {
  DairOptions options;
  std::uint64_t seed = 0;
  CLI::Option* seed_option = nullptr;
  std::string mode = "global", prior = "none";
  DairRecordingOptions recording;
  bool no_offset = false;
};

CLI::App* add_kitti_command(CLI::App& app, KittiCommand& k, bool& json) {
  CLI::App* cmd = app.add_subcommand(
      "kitti", "LiDAR odometry over a KITTI odometry sequence (velodyne/*.bin, times.txt, calib.txt); "
               "KITTI metrics when ground-truth poses exist");
  cmd->add_option("SEQ_DIR", k.options.seq_dir, "sequence folder, e.g. dataset/sequences/00")
      ->required()->check(CLI::ExistingDirectory);
  cmd->add_option("--out", k.out, "write the estimated poses here (KITTI format, camera 0 frame)");
  cmd->add_option("--poses", k.poses, "ground-truth poses (default: SEQ_DIR/poses.txt, then ../../poses/<SEQ>.txt)");
  cmd->add_option("--voxel", k.voxel, "odometry voxel size [m] (KISS-ICP: max range / 100)")
      ->check(CLI::Range(0.05, 10.0));
  cmd->add_flag("--json", json, "print one JSON object instead of the table");
  return cmd;
}

// dair-v2x-c --recording OUT and the options that shape the recording.
void add_recording_options(CLI::App* cmd, DairCommand& d) {
  DairRecordingOptions& recording = d.recording;
  cmd->add_option("--recording", recording.out_dir,
                  "write the cooperative sequence as a v2xloc recording in this folder (no registration)");
  cmd->add_option("--batch", recording.batch, "with --recording: the vehicle-side batch_id (sequence) to convert");
  cmd->add_option("--noise-seed", recording.seed, "with --recording: seed of the GNSS and vehicle-signal noise");
  cmd->add_option("--gnss-epoch-hour", recording.gnss_epoch_hour,
                  "with --recording: constellation time of the drive [h after the simulator's epoch]")
      ->check(CLI::Range(0.0, 24.0));
  cmd->add_option("--gnss-canyon-setback", recording.gnss_canyon_setback_m,
                  "with --recording: the drive's start before the simulated intersection [m]")
      ->check(CLI::Range(0.0, 120.0));
  cmd->add_option("--background-min-share", recording.background_min_share,
                  "with --recording: share of the roadside sweeps that must hit a cell for the background")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag("--no-system-error-offset", d.no_offset,
                "with --recording: leave cooperative/data_info.json's system_error_offset off the roadside pose");
}

CLI::App* add_dair_command(CLI::App& app, DairCommand& d, bool& json) {
  DairOptions& dair = d.options;
  CLI::App* cmd = app.add_subcommand(
      "dair-v2x-c", "registration of each infrastructure cloud to its vehicle cloud with a verdict, scored against "
                    "the dataset's transform (cooperative/calib/lidar_i2v, else the per-frame calibrations)");
  cmd->add_option("ROOT", dair.root, "folder holding cooperative/, vehicle-side/, infrastructure-side/")
      ->required()->check(CLI::ExistingDirectory);
  cmd->add_option("--voxel", dair.voxel, "registration voxel size [m]")->check(CLI::Range(0.05, 10.0));
  cmd->add_option("--mode", d.mode,
                  "global: FPFH + RANSAC + ICP (default); search: level search (x, y, yaw) + ICP; "
                  "icp: ICP from the prior")
      ->check(CLI::IsMember({"global", "search", "icp"}));
  cmd->add_option("--prior", d.prior,
                  "none (default) or gnss: the dataset's transform perturbed (--prior-translation, "
                  "--prior-yaw, --prior-seed); search searches around it, icp starts from it")
      ->check(CLI::IsMember({"none", "gnss"}));
  cmd->add_option("--prior-translation", dair.prior_translation_m, "GNSS-grade prior: position error [m]")
      ->check(CLI::Range(0.0, 50.0));
  cmd->add_option("--prior-yaw", dair.prior_yaw_deg, "GNSS-grade prior: heading error [deg]")
      ->check(CLI::Range(0.0, 45.0));
  cmd->add_option("--prior-seed", dair.prior_seed, "GNSS-grade prior: random seed");
  d.seed_option = cmd->add_option("--seed", d.seed, "RANSAC random seed");
  cmd->add_option("--limit", dair.limit, "register at most N pairs (0 = all)");
  cmd->add_option("--success-translation", dair.success_translation_m,
                  "summary: a pair succeeds within this translation error [m]");
  cmd->add_option("--success-rotation", dair.success_rotation_deg,
                  "summary: a pair succeeds within this rotation error [deg]");
  cmd->add_flag("--json", json, "print one JSON object instead of the table");
  add_recording_options(cmd, d);
  return cmd;
}

int run_kitti_command(KittiCommand& k, bool json) {
  k.options.odometry.voxel_size = k.voxel;
  if (!k.out.empty()) k.options.out_path = k.out;
  if (!k.poses.empty()) k.options.poses_path = k.poses;
  KittiRunResult result;
  std::string error;
  if (!run_kitti(k.options, result, error)) {
    std::fprintf(stderr, "v2xloc-dataset kitti: %s\n", error.c_str());
    return 2;
  }
  std::fputs(json ? (kitti_json(k.options, result).dump() + "\n").c_str() : kitti_table(k.options, result).c_str(),
             stdout);
  return 0;
}

int write_recording(DairCommand& d) {
  d.recording.root = d.options.root;
  d.recording.system_error_offset = !d.no_offset;
  DairRecordingSummary summary;
  std::string error;
  if (!write_dair_recording(d.recording, summary, error)) {
    std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: %s\n", error.c_str());
    return 2;
  }
  std::printf("%s: %s\n", d.recording.out_dir.c_str(), summary.one_line().c_str());
  return 0;
}

int run_dair_command(DairCommand& d, bool json) {
  DairOptions& dair = d.options;
  if (*d.seed_option) dair.seed = d.seed;
  if (!d.recording.out_dir.empty()) return write_recording(d);
  dair.mode = d.mode == "search" ? v2xloc::RegistrationMode::kLevelSearch
              : d.mode == "icp"  ? v2xloc::RegistrationMode::kIcpOnly
                                 : v2xloc::RegistrationMode::kGlobal;
  dair.prior = d.prior == "gnss" ? DairPrior::kGnss : DairPrior::kNone;
  if (dair.mode == v2xloc::RegistrationMode::kIcpOnly && dair.prior != DairPrior::kGnss) {
    std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: --mode icp needs a prior (--prior gnss)\n");
    return 2;
  }
  DairRunResult result;
  std::string error;
  if (!run_dair(dair, result, error)) {
    std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: %s\n", error.c_str());
    return 2;
  }
  std::fputs(json ? (dair_json(dair, result).dump() + "\n").c_str() : dair_table(dair, result).c_str(), stdout);
  if (dair_summary(dair, result).ok == 0) {
    std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: %s\n", dair_nothing_registered(result).c_str());
    return 1;
  }
  for (const DairPairResult& r : result.pairs)
    if (r.status != "ok") return 1;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Runs the v2xloc core on KITTI odometry sequences and DAIR-V2X-C cooperative pairs"};
  app.require_subcommand(1);
  bool json = false;
  KittiCommand kitti;
  DairCommand dair;
  CLI::App* kitti_cmd = add_kitti_command(app, kitti, json);
  add_dair_command(app, dair, json);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  return kitti_cmd->parsed() ? run_kitti_command(kitti, json) : run_dair_command(dair, json);
}
