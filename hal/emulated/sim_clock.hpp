// Simulated clock: monotonic time moves only through advance_to()/advance_by() (or, in
// kJumpOnSleep mode, through sleep_until(), which then jumps instead of waiting). Replay can run
// faster than real time and gives the same result on every run.
#pragma once

#include <atomic>
#include <cstdint>

#include "hal/clock.hpp"

namespace v2xloc::hal {

class SimClock final : public Clock {
 public:
  enum class SleepMode : std::uint8_t {
    kExternal,     // sleep_until() never moves time: kOk if the deadline passed, else kWouldBlock
    kJumpOnSleep,  // sleep_until() advances time to the deadline (the sleeper drives time)
  };

  explicit SimClock(std::int64_t start_monotonic_ns = 0, std::int64_t time_offset_ns = 0,
                    SleepMode mode = SleepMode::kExternal)
      : monotonic_ns_(start_monotonic_ns), offset_ns_(time_offset_ns), mode_(mode) {}

  std::int64_t monotonic_ns() const override { return monotonic_ns_.load(std::memory_order_acquire); }
  std::int64_t time_ns() const override { return monotonic_ns() + offset_ns_.load(std::memory_order_relaxed); }
  Status set_time(std::int64_t reference_time_ns, std::int64_t at_monotonic_ns) override;
  Status sleep_until(std::int64_t monotonic_deadline_ns) override;

  // Time never goes backwards: an earlier target is kInvalidArgument and changes nothing.
  Status advance_to(std::int64_t monotonic_ns);
  Status advance_by(std::int64_t delta_ns);

 private:
  std::atomic<std::int64_t> monotonic_ns_;
  std::atomic<std::int64_t> offset_ns_;
  SleepMode mode_;
};

}  // namespace v2xloc::hal
