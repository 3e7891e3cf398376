// Replays a recording into a running v2xloc-firmware (started here by fork/exec, or connected to)
// over emulated CAN (CAN frames as struct can_frame bytes in UDP) and UDP point clouds, in
// lockstep: send frame i's events (canonical order, event_stream.hpp), preceded by sim-time frames
// that drive the firmware's SimClock, then wait for the pose frames of frame i (0x200, 0x201 with
// frame counter i, 0x202) with a timeout. Nothing depends on wall-clock speed.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "firmware/wire/diagnostic_frames.hpp"
#include "firmware/wire/pose_frames.hpp"
#include "host_sim/eval/trajectory.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/replay/event_stream.hpp"

namespace v2xloc::sim::replay {

struct ReplayedFrame;

struct ReplayOptions {
  std::string firmware_path;           // non-empty: fork/exec `firmware_path --emulated ...`
  std::vector<std::string> firmware_args;  // extra arguments for the started firmware
  std::string host = "127.0.0.1";      // connect mode: the firmware's address and ports
  std::uint16_t firmware_can_port = 0;
  std::uint16_t firmware_cloud_port = 0;
  std::uint16_t firmware_ego_port = 0;     // connect mode: 0 = ego scans to the cloud port
  std::uint16_t local_can_port = 0;    // our CAN-over-UDP port (0 = ephemeral; connect mode: the
                                       // firmware's --can-peer-port)
  double frame_timeout_s = 60.0;       // per frame, waiting for the pose and diagnostic frames
  double startup_timeout_s = 30.0;
  EventStreamConfig stream;
  bool verbose = false;
  std::function<void(const ReplayedFrame&)> on_frame;  // optional: called per completed frame
};

struct ReplayedFrame {
  int frame = -1;
  double t = 0.0;                      // recording time of the frame
  firmware::PoseFrames pose{};         // the three CAN frames as received
  protocol::PosePosition position{};
  protocol::PoseAttitude attitude{};
  protocol::PoseSigma sigma{};
  firmware::DiagnosticFrames diagnostics{};  // the five diagnostic CAN frames as received
  protocol::RegistrationPosition registration_position{};
  protocol::RegistrationQuality registration_quality{};
  protocol::GateDecision gate{};
  protocol::OdometryPosition odometry_position{};
  protocol::OdometryAttitude odometry_attitude{};
};

struct ReplayResult {
  // One per period the firmware published for a recording frame (frame: the recording's), in order.
  std::vector<ReplayedFrame> frames;
  int frames_without_scan = 0;         // recording frames whose ego scan was not sent (lidar-blind)
  int periods_without_scan = 0;        // periods the firmware's timer closed (period_timer.hpp)
  int frames_without_pose = 0;         // recording frames no period stands for (late scan, recording end)
  int late_scans = 0;                  // scans for a period the timer had closed (the firmware drops them)
  int timeouts = 0;
  std::size_t heartbeats = 0;
  std::size_t pose_decode_errors = 0;
  std::size_t diagnostic_decode_errors = 0;
  std::size_t datagrams_sent = 0, can_frames_sent = 0, send_retries = 0;
  EventStreamStats stream_stats{};
  std::string firmware_output;         // the started firmware's stdout (memory, counters)
  int firmware_exit_code = -1;
  double wall_seconds = 0.0;
};

// False + error on set-up failures, timeouts (after the first timed-out frame the replay stops)
// or a firmware that exited abnormally.
bool replay_recording(const RecordingReader& reader, const ReplayOptions& options, ReplayResult& result,
                      std::string& error);

// Pose frames -> TUM trajectory (x, y, z, yaw; roll = pitch = 0 as the DBC carries no more).
StampedTrajectory pose_frames_to_trajectory(const std::vector<ReplayedFrame>& frames);
StampedTrajectory ground_truth_trajectory(const RecordingReader& reader);

}  // namespace v2xloc::sim::replay
