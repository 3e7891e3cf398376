// Time for the firmware: a monotonic nanosecond counter for scheduling and time stamps, and a
// settable "disciplined" time (e.g. GNSS time aligned on the PPS edge) derived from it by an
// offset. The simulated clock advances only when told, so replay is deterministic.
#pragma once

#include <cstdint>

#include "hal/status.hpp"

namespace v2xloc::hal {

class Clock {
 public:
  virtual ~Clock() = default;
  virtual std::int64_t monotonic_ns() const = 0;
  // Disciplined time: monotonic_ns() + offset. Initially the host's wall clock (real clock) or 0
  // plus the start offset (simulated clock).
  virtual std::int64_t time_ns() const = 0;
  // Discipline: from now on, time_ns() at monotonic time `at_monotonic_ns` equals
  // `reference_time_ns` (e.g. the GNSS second that the PPS edge at that monotonic time marks).
  virtual Status set_time(std::int64_t reference_time_ns, std::int64_t at_monotonic_ns) = 0;
  // Sleeps until monotonic_ns() >= deadline. The simulated clock either jumps to the deadline or
  // returns kWouldBlock, depending on its mode (see hal/emulated/sim_clock.hpp).
  virtual Status sleep_until(std::int64_t monotonic_deadline_ns) = 0;
};

}  // namespace v2xloc::hal
