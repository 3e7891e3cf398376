#include "hal/emulated/sim_clock.hpp"

#include <gtest/gtest.h>

#include "hal/linux/linux_clock.hpp"

namespace v2xloc::hal {
namespace {

TEST(SimClock, MovesOnlyWhenTold) {
  SimClock clock(1000, 5'000);
  EXPECT_EQ(clock.monotonic_ns(), 1000);
  EXPECT_EQ(clock.time_ns(), 6000);
  EXPECT_EQ(clock.sleep_until(2000), Status::kWouldBlock);  // external mode: no jump
  EXPECT_EQ(clock.monotonic_ns(), 1000);
  EXPECT_EQ(clock.advance_by(500), Status::kOk);
  EXPECT_EQ(clock.advance_to(2000), Status::kOk);
  EXPECT_EQ(clock.sleep_until(2000), Status::kOk);
  EXPECT_EQ(clock.advance_to(1999), Status::kInvalidArgument);  // never backwards
  EXPECT_EQ(clock.advance_by(-1), Status::kInvalidArgument);
  EXPECT_EQ(clock.monotonic_ns(), 2000);
}

TEST(SimClock, JumpOnSleepAndDiscipline) {
  SimClock clock(0, 0, SimClock::SleepMode::kJumpOnSleep);
  EXPECT_EQ(clock.sleep_until(100'000'000), Status::kOk);
  EXPECT_EQ(clock.monotonic_ns(), 100'000'000);
  EXPECT_EQ(clock.sleep_until(50), Status::kOk);  // past deadline: no change
  EXPECT_EQ(clock.monotonic_ns(), 100'000'000);
  // GNSS second 1'700'000'000 s marked by a PPS edge at monotonic 90 ms.
  ASSERT_EQ(clock.set_time(1'700'000'000'000'000'000, 90'000'000), Status::kOk);
  EXPECT_EQ(clock.time_ns(), 1'700'000'000'010'000'000);
}

TEST(LinuxClock, SleepUntilReachesTheDeadlineAndTimeIsSettable) {
  LinuxClock clock;
  const std::int64_t start = clock.monotonic_ns();
  ASSERT_EQ(clock.sleep_until(start + 2'000'000), Status::kOk);
  EXPECT_GE(clock.monotonic_ns(), start + 2'000'000);
  ASSERT_EQ(clock.set_time(42'000'000'000, start), Status::kOk);
  const std::int64_t t = clock.time_ns();
  EXPECT_GE(t, 42'002'000'000);
  EXPECT_LT(t, 42'000'000'000 + 5'000'000'000);
}

}  // namespace
}  // namespace v2xloc::hal
