#include "hal/emulated/sim_clock.hpp"

namespace v2xloc::hal {

Status SimClock::set_time(std::int64_t reference_time_ns, std::int64_t at_monotonic_ns) {
  offset_ns_.store(reference_time_ns - at_monotonic_ns, std::memory_order_relaxed);
  return Status::kOk;
}

Status SimClock::advance_to(std::int64_t target_ns) {
  std::int64_t now = monotonic_ns_.load(std::memory_order_acquire);
  while (true) {
    if (target_ns < now) return Status::kInvalidArgument;
    if (monotonic_ns_.compare_exchange_weak(now, target_ns, std::memory_order_acq_rel)) return Status::kOk;
  }
}

Status SimClock::advance_by(std::int64_t delta_ns) {
  if (delta_ns < 0) return Status::kInvalidArgument;
  monotonic_ns_.fetch_add(delta_ns, std::memory_order_acq_rel);
  return Status::kOk;
}

Status SimClock::sleep_until(std::int64_t deadline_ns) {
  if (monotonic_ns() >= deadline_ns) return Status::kOk;
  if (mode_ == SleepMode::kJumpOnSleep) {
    (void)advance_to(deadline_ns);  // fails only if another thread already moved past it
    return Status::kOk;
  }
  return Status::kWouldBlock;
}

}  // namespace v2xloc::hal
