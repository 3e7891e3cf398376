// Real clock: CLOCK_MONOTONIC for scheduling and stamps, a process-local disciplined time
// (monotonic + offset; initialised from CLOCK_REALTIME, re-set e.g. from GNSS + PPS). It never
// touches the system clock, so it needs no privileges.
#pragma once

#include <atomic>
#include <cstdint>
#include <ctime>

#include "hal/clock.hpp"

namespace v2xloc::hal {

class LinuxClock final : public Clock {
 public:
  LinuxClock();
  std::int64_t monotonic_ns() const override;
  std::int64_t time_ns() const override;
  Status set_time(std::int64_t reference_time_ns, std::int64_t at_monotonic_ns) override;
  Status sleep_until(std::int64_t monotonic_deadline_ns) override;

 private:
  std::atomic<std::int64_t> offset_ns_{0};
};

std::int64_t to_ns(const timespec& ts);
// Kernel receive stamps (SO_TIMESTAMPNS) are CLOCK_REALTIME; re-express them on the monotonic
// base by their age at read time (error: the few microseconds between the two clock reads).
std::int64_t realtime_stamp_to_monotonic_ns(const timespec& kernel_realtime);

}  // namespace v2xloc::hal
