// Localizer frame output -> the five diagnostic CAN frames (tools/dbc/v2xloc.dbc 0x210..0x214),
// published once per ego frame after the pose frames: this frame's registration (0x210 x/y +
// flags, 0x211 z/fitness/RMSE + frame counter), the fixed-lag gate decision that became available
// (0x212) and the odometry pose odom_T_body (0x213 x/y, 0x214 z/yaw + frame counter; sent last).
// With the pose frames they carry every input of the paper's Table 1 (tools/eval/firmware_run).
#pragma once

#include <cstdint>

#include "firmware/protocol/can_messages.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

struct DiagnosticFrames {
  hal::CanFrame registration_position;
  hal::CanFrame registration_quality;
  hal::CanFrame gate;
  hal::CanFrame odometry_position;
  hal::CanFrame odometry_attitude;  // last: the replayer's lockstep waits for it
};

// Stateful only in the 4-bit rolling counter (one per diagnostic message, advanced together).
class DiagnosticFrameEncoder {
 public:
  // frame_index: ego scans processed - 1 (as the pose frames; wraps at 65536).
  DiagnosticFrames encode(const LocalizerFrameOutput& out, std::uint32_t frame_index);
  std::uint32_t saturated_signals() const { return saturated_; }

 private:
  std::uint8_t counter_ = 0;
  std::uint32_t saturated_ = 0;
};

}  // namespace v2xloc::firmware
