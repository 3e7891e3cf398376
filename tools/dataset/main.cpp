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

#include <cstdio>
#include <string>

int main(int argc, char** argv) {
  using namespace v2xloc::dataset;
  CLI::App app{"Runs the v2xloc core on KITTI odometry sequences and DAIR-V2X-C cooperative pairs"};
  app.require_subcommand(1);
  bool json = false;

  KittiRunOptions kitti;
  double kitti_voxel = kitti.odometry.voxel_size;
  std::string kitti_out, kitti_poses;
  CLI::App* kitti_cmd = app.add_subcommand(
      "kitti", "LiDAR odometry over a KITTI odometry sequence (velodyne/*.bin, times.txt, calib.txt); "
               "KITTI metrics when ground-truth poses exist");
  kitti_cmd->add_option("SEQ_DIR", kitti.seq_dir, "sequence folder, e.g. dataset/sequences/00")
      ->required()->check(CLI::ExistingDirectory);
  kitti_cmd->add_option("--out", kitti_out, "write the estimated poses here (KITTI format, camera 0 frame)");
  kitti_cmd->add_option("--poses", kitti_poses,
                        "ground-truth poses (default: SEQ_DIR/poses.txt, then ../../poses/<SEQ>.txt)");
  kitti_cmd->add_option("--voxel", kitti_voxel, "odometry voxel size [m] (KISS-ICP: max range / 100)")
      ->check(CLI::Range(0.05, 10.0));
  kitti_cmd->add_flag("--json", json, "print one JSON object instead of the table");

  DairOptions dair;
  std::uint64_t seed = 0;
  std::string dair_mode = "global", dair_prior = "none";
  CLI::App* dair_cmd = app.add_subcommand(
      "dair-v2x-c", "registration of each infrastructure cloud to its vehicle cloud with a verdict, scored against "
                    "the dataset's transform (cooperative/calib/lidar_i2v, else the per-frame calibrations)");
  dair_cmd->add_option("ROOT", dair.root, "folder holding cooperative/, vehicle-side/, infrastructure-side/")
      ->required()->check(CLI::ExistingDirectory);
  dair_cmd->add_option("--voxel", dair.voxel, "registration voxel size [m]")->check(CLI::Range(0.05, 10.0));
  dair_cmd->add_option("--mode", dair_mode,
                       "global: FPFH + RANSAC + ICP (default); search: level search (x, y, yaw) + ICP; "
                       "icp: ICP from the prior")
      ->check(CLI::IsMember({"global", "search", "icp"}));
  dair_cmd->add_option("--prior", dair_prior,
                       "none (default) or gnss: the dataset's transform perturbed (--prior-translation, "
                       "--prior-yaw, --prior-seed); search searches around it, icp starts from it")
      ->check(CLI::IsMember({"none", "gnss"}));
  dair_cmd->add_option("--prior-translation", dair.prior_translation_m, "GNSS-grade prior: position error [m]")
      ->check(CLI::Range(0.0, 50.0));
  dair_cmd->add_option("--prior-yaw", dair.prior_yaw_deg, "GNSS-grade prior: heading error [deg]")
      ->check(CLI::Range(0.0, 45.0));
  dair_cmd->add_option("--prior-seed", dair.prior_seed, "GNSS-grade prior: random seed");
  CLI::Option* seed_opt = dair_cmd->add_option("--seed", seed, "RANSAC random seed");
  dair_cmd->add_option("--limit", dair.limit, "register at most N pairs (0 = all)");
  dair_cmd->add_option("--success-translation", dair.success_translation_m,
                       "summary: a pair succeeds within this translation error [m]");
  dair_cmd->add_option("--success-rotation", dair.success_rotation_deg,
                       "summary: a pair succeeds within this rotation error [deg]");
  dair_cmd->add_flag("--json", json, "print one JSON object instead of the table");
  DairRecordingOptions recording;
  dair_cmd->add_option("--recording", recording.out_dir,
                       "write the cooperative sequence as a v2xloc recording in this folder (no registration)");
  dair_cmd->add_option("--batch", recording.batch, "with --recording: the vehicle-side batch_id (sequence) to convert");
  dair_cmd->add_option("--noise-seed", recording.seed, "with --recording: seed of the GNSS and vehicle-signal noise");
  dair_cmd->add_option("--gnss-epoch-hour", recording.gnss_epoch_hour,
                       "with --recording: constellation time of the drive [h after the simulator's epoch]")
      ->check(CLI::Range(0.0, 24.0));
  dair_cmd->add_option("--gnss-canyon-setback", recording.gnss_canyon_setback_m,
                       "with --recording: the drive's start before the simulated intersection [m]")
      ->check(CLI::Range(0.0, 120.0));
  dair_cmd->add_option("--background-min-share", recording.background_min_share,
                       "with --recording: share of the roadside sweeps that must hit a cell for the background")
      ->check(CLI::Range(0.0, 1.0));
  bool no_offset = false;
  dair_cmd->add_flag("--no-system-error-offset", no_offset,
                     "with --recording: leave cooperative/data_info.json's system_error_offset off the roadside pose");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }

  std::string error;
  if (kitti_cmd->parsed()) {
    kitti.odometry.voxel_size = kitti_voxel;
    if (!kitti_out.empty()) kitti.out_path = kitti_out;
    if (!kitti_poses.empty()) kitti.poses_path = kitti_poses;
    KittiRunResult result;
    if (!run_kitti(kitti, result, error)) {
      std::fprintf(stderr, "v2xloc-dataset kitti: %s\n", error.c_str());
      return 2;
    }
    std::fputs(json ? (kitti_json(kitti, result).dump() + "\n").c_str() : kitti_table(kitti, result).c_str(),
               stdout);
    return 0;
  }
  if (*seed_opt) dair.seed = seed;
  if (!recording.out_dir.empty()) {
    recording.root = dair.root;
    recording.system_error_offset = !no_offset;
    DairRecordingSummary summary;
    if (!write_dair_recording(recording, summary, error)) {
      std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: %s\n", error.c_str());
      return 2;
    }
    std::printf("%s: %s\n", recording.out_dir.c_str(), summary.one_line().c_str());
    return 0;
  }
  dair.mode = dair_mode == "search" ? v2xloc::RegistrationMode::kLevelSearch
              : dair_mode == "icp"  ? v2xloc::RegistrationMode::kIcpOnly
                                    : v2xloc::RegistrationMode::kGlobal;
  dair.prior = dair_prior == "gnss" ? DairPrior::kGnss : DairPrior::kNone;
  if (dair.mode == v2xloc::RegistrationMode::kIcpOnly && dair.prior != DairPrior::kGnss) {
    std::fprintf(stderr, "v2xloc-dataset dair-v2x-c: --mode icp needs a prior (--prior gnss)\n");
    return 2;
  }
  DairRunResult result;
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
