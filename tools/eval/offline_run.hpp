// Runs the localizer over a recording in process and keeps one record per frame for the
// evaluation. The recording is sent as the firmware receives it (host_sim/replay's event stream:
// the CAN log, signed shares) through the firmware's decoder and period driver, which decide what
// reaches the localizer and when (trust checks, surveyed pose and background, share schedule);
// the localizer then gets the recorded clouds at full precision (tools/eval/in_process_port.hpp).
// So the in-process and firmware paths fuse the same shares in the same periods and differ by the
// wire's 4 mm quantization of the points.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "firmware/trust/map_share_verifier.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "v2xloc/algo/localization/localizer.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc::eval {

struct FrameRecord {
  double t = 0.0;
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();  // body -> ENU
  bool has_gnss = false;
  Eigen::Vector3d gnss_body = Eigen::Vector3d::Zero();       // latest fix, antenna lever removed
  LocalizerFrameOutput out;                                  // the localizer's frame output
  // The output as revised within the localizer's backfill lag (trajectory_backfill.hpp): the
  // live output unless the filter's start revised this frame.
  Mat4d lagged_pose = Mat4d::Identity();
  bool revised = false;
  bool gate_valid = false;     // fixed-lag decision for this frame (arrives w/2 frames later)
  bool gate_decided = false;
};

struct RunOptions {
  LocalizerParams params{};
  int max_frames = -1;                                     // -1: all
  Eigen::Vector3d gnss_antenna_in_body{0.0, 0.0, 1.75};    // recording's GNSS lever arm [m]
  bool quiet = false;
  // Per-period host time by stage (v2xloc-eval --timing): the period is everything the localizer
  // does for one frame (CAN inputs up to the frame, map clouds, the ego scan); recording I/O is
  // not in it.
  bool timing = false;
  // Under valgrind --tool=callgrind: one CALLGRIND_DUMP_STATS per stage of every period, labelled
  // "frame N stage" (tools/timing/frame_instructions.py reads them). No effect otherwise.
  bool callgrind_dumps = false;
};

// Host milliseconds of one period, by LocalizerStage (stage_probe.hpp).
using StageMs = std::array<double, static_cast<std::size_t>(LocalizerStage::kCount)>;

struct RunStats {
  double seconds = 0.0;          // wall time of the localizer calls only
  double max_frame_ms = 0.0;
  LocalizerCounters counters{};
  std::size_t can_decode_errors = 0;
  std::size_t map_clouds = 0;           // verified shares handed to map fusion
  std::size_t map_clouds_rejected = 0;  // of those: refused (inconsistent, off the surveyed background)
  std::size_t map_shares_untrusted = 0;  // refused by the trust checks (trust: by reason) or off the background before ECDSA
  std::size_t map_clouds_paced = 0;     // not handed to the map: the source's stored cloud is recent (map.cloud_interval)
  std::size_t map_clouds_dropped = 0;    // waited beyond the share queue (the firmware's schedule)
  std::size_t backgrounds_loaded = 0;    // surveyed backgrounds the recording's trust list names
  std::uint64_t map_background_checked = 0;   // infrastructure clouds scored against them
  std::uint64_t map_background_mismatch = 0;  // of those: refused
  trust::VerifierCounters trust{};       // the share verifier's counts (in process; zero through --firmware)
  std::vector<StageMs> period_stage_ms;  // one per frame when RunOptions::timing
  int frames_without_pose = 0;           // --firmware: frames no period stands for (late scan, recording end)
};

struct TimingSummary {
  double median_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
  int worst_frame = -1;
  StageMs worst_stages_ms{};   // the worst period's breakdown
  StageMs median_stages_ms{};  // per stage, the median over periods
};
// Empty (worst_frame -1) without timing data.
TimingSummary summarize_timing(const std::vector<StageMs>& periods);

// Copies the latest pose of every frame the backfill still holds (records up to `newest`) into
// lagged_pose / revised: called after each frame, a record's value is final once it leaves.
void take_revisions(const TrajectoryBackfill& backfill, std::size_t newest, std::vector<FrameRecord>& records);

// `localizer` must be static storage (it holds every buffer). Returns false with `error` set
// when the recording cannot be read.
bool run_offline(const sim::RecordingReader& reader, Localizer& localizer, const RunOptions& options,
                 std::vector<FrameRecord>& records, RunStats& stats, std::string& error);

}  // namespace v2xloc::eval
