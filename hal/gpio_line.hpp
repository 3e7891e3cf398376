// One GPIO line: edge events with time stamps (e.g. GNSS PPS) or an output (status LED).
#pragma once

#include <cstdint>

#include "hal/status.hpp"

namespace v2xloc::hal {

struct GpioEdge {
  enum class Kind : std::uint8_t { kRising, kFalling };
  Kind kind = Kind::kRising;
  std::int64_t timestamp_ns = 0;  // kernel event time (CLOCK_MONOTONIC) / Clock::monotonic_ns
};

class GpioLine {
 public:
  virtual ~GpioLine() = default;
  // Next queued edge, kWouldBlock when none (input lines only).
  virtual Status read_edge(GpioEdge& edge) = 0;
  virtual Status set_value(bool active) = 0;   // output lines only
  virtual Status get_value(bool& active) = 0;
};

}  // namespace v2xloc::hal
