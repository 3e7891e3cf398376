// The firmware path of v2xloc-eval (--firmware): replays a recording through a v2xloc-firmware
// process over emulated CAN + UDP (host_sim/replay, lockstep, simulated clock) and rebuilds the
// evaluator's per-frame records from what the firmware publishes on CAN:
//   fused pose / sigma / flags  <- 0x200 PosePosition, 0x201 PoseAttitude, 0x202 PoseSigma
//   registration                <- 0x210 RegistrationPosition, 0x211 RegistrationQuality
//   validity-gate decision      <- 0x212 GateDecision (applied to the frame it decides)
//   odometry odom_T_body        <- 0x213 OdometryPosition, 0x214 OdometryAttitude
//   truth, GNSS                 <- the recording, exactly as the in-process path derives them.
// Resolution is the DBC's: 1 mm (fused z: 1 cm), yaw 1e-4 rad, fitness/RMSE 0.001. Not carried:
// the registration's rotation and exact failure status, the shadow (ungated) filter.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/replay/replay_session.hpp"
#include "tools/eval/metrics.hpp"
#include "tools/eval/offline_run.hpp"

namespace v2xloc::eval {

struct FirmwareRunOptions {
  std::string firmware_path;                              // v2xloc-firmware executable
  int max_frames = -1;                                    // -1: all
  Eigen::Vector3d gnss_antenna_in_body{0.0, 0.0, 1.75};   // as RunOptions
  double frame_timeout_s = 120.0;                         // per frame (lockstep)
  bool quiet = false;
  sim::replay::FaultSpec faults{};                        // --faults SPEC (fault_injection.hpp)
  bool report = false;  // the firmware's and the injector's counts on stderr even when quiet (--faults given)
};

// Replays `reader` through the firmware and fills one record per frame. RunStats: seconds = wall
// time of the whole replay, can_decode_errors = pose + diagnostic frames that failed to decode,
// map_clouds = clouds sent; the localizer's internal counters are not on the wire (zero).
bool run_firmware(const sim::RecordingReader& reader, const FirmwareRunOptions& options,
                  std::vector<FrameRecord>& records, RunStats& stats, std::string& error);

// One frame's CAN output -> the localizer output fields the metrics, plots and traces read.
// frame_index is the replayed frame's index (the 16-bit frame counters are unwrapped against it).
LocalizerFrameOutput output_from_can(const sim::replay::ReplayedFrame& frame, std::uint32_t frame_index);

// Records from per-period outputs: truth and GNSS from the recording (fill_gnss, as run_offline: latest valid
// fix with t <= frame time, lever arm removed), fixed-lag decisions applied to the periods they
// decide. outputs[i] belongs to recording frame recording_frames[i] (empty: frame i). False + error
// when the CAN log cannot be read or a frame has no ground truth.
bool records_from_outputs(const sim::RecordingReader& reader, const std::vector<LocalizerFrameOutput>& outputs,
                          const Eigen::Vector3d& gnss_antenna_in_body, std::vector<FrameRecord>& records,
                          std::string& error, const std::vector<int>& recording_frames = {});

// Marks the columns the CAN interface does not carry as unavailable (null in JSON): fused_ungated,
// the registration offset's yaw.
void mark_columns_not_on_can(RowMetrics& metrics);

}  // namespace v2xloc::eval
