// Localizer frame output -> the three pose CAN frames of the DBC (0x200 position, 0x201 attitude
// with the frame counter, 0x202 sigmas), and the 1 Hz heartbeat (0x300). Used by the firmware to
// publish and by the offline evaluator to produce the frames the firmware must match bit for bit.
#pragma once

#include <cstdint>

#include "firmware/protocol/can_messages.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

namespace v2xloc::firmware {

struct PoseFrames {
  hal::CanFrame position;
  hal::CanFrame attitude;
  hal::CanFrame sigma;
};

protocol::PoseFlags pose_flags(const LocalizerFrameOutput& out, bool gnss_used);

// Stateful only in the 4-bit rolling counter (one per pose message, advanced together).
class PoseFrameEncoder {
 public:
  // frame_index: ego scans processed - 1 (ties the three frames; wraps at 65536).
  PoseFrames encode(const LocalizerFrameOutput& out, std::uint32_t frame_index, bool gnss_used);
  std::uint32_t saturated_signals() const { return saturated_; }

 private:
  std::uint8_t counter_ = 0;
  std::uint32_t saturated_ = 0;
};

// Heartbeat state from the latest frame output (nullptr before the first ego scan).
protocol::LocalizerState localizer_state(const LocalizerFrameOutput* latest);

}  // namespace v2xloc::firmware
