#include "hal/linux/linux_clock.hpp"

#include <cerrno>

namespace v2xloc::hal {
namespace {

std::int64_t now_ns(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return to_ns(ts);
}

}  // namespace

std::int64_t to_ns(const timespec& ts) {
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + static_cast<std::int64_t>(ts.tv_nsec);
}

std::int64_t realtime_stamp_to_monotonic_ns(const timespec& kernel_realtime) {
  const std::int64_t mono = now_ns(CLOCK_MONOTONIC);
  const std::int64_t age = now_ns(CLOCK_REALTIME) - to_ns(kernel_realtime);
  return mono - (age > 0 ? age : 0);
}

LinuxClock::LinuxClock() { offset_ns_ = now_ns(CLOCK_REALTIME) - now_ns(CLOCK_MONOTONIC); }

std::int64_t LinuxClock::monotonic_ns() const { return now_ns(CLOCK_MONOTONIC); }

std::int64_t LinuxClock::time_ns() const { return monotonic_ns() + offset_ns_.load(std::memory_order_relaxed); }

Status LinuxClock::set_time(std::int64_t reference_time_ns, std::int64_t at_monotonic_ns) {
  offset_ns_.store(reference_time_ns - at_monotonic_ns, std::memory_order_relaxed);
  return Status::kOk;
}

Status LinuxClock::sleep_until(std::int64_t monotonic_deadline_ns) {
  if (monotonic_deadline_ns < 0) return Status::kInvalidArgument;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(monotonic_deadline_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(monotonic_deadline_ns % 1'000'000'000);
  int rc = 0;
  while ((rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr)) == EINTR) {
  }
  return rc == 0 ? Status::kOk : Status::kIoError;
}

}  // namespace v2xloc::hal
