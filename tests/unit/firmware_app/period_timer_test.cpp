// The period timer (firmware/wire/period_timer.hpp) in the period driver and the application: a
// period whose scan does not come is closed on the inputs' clock with an empty scan stamped at the
// expected time, a late scan is counted and not used, a scan after a silence closes the skipped
// periods first, and the heartbeat flags a silent LiDAR while V2X shares keep the UDP alive.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "firmware/app/emulated_wiring.hpp"
#include "firmware/app/firmware_app.hpp"
#include "scripted_io.hpp"

namespace v2xloc::firmware {
namespace {

using test::kEpoch;

hal::CanFrame vehicle_frame(int k) {
  protocol::VehicleMotion vm;
  vm.wheel_speed_mps = 5.0;
  vm.speed_valid = vm.yaw_rate_valid = true;
  vm.counter = static_cast<std::uint8_t>(k % protocol::kCounterModulo);
  return protocol::pack(vm);
}

struct Published {
  std::uint32_t frame_index = 0;
  bool without_scan = false;
};

// A period driver over a recording port; CAN vehicle frames and ego scans stamped in localizer
// seconds (the inputs' clock).
class PeriodTimerDriver : public ::testing::Test {
 protected:
  void can_at(double t) { driver.on_can(vehicle_frame(can_frames_++), kEpoch + std::llround(t * 1e9)); }
  void scan_at(double t) {
    DecodedCloud scan;
    scan.kind = CloudKind::kEgoScan;
    scan.ego.t = t;
    scan.ego.points = points;
    driver.close_period(scan, [&](const PeriodOutput& p) { published.push_back({p.frame_index, p.without_scan}); });
  }
  void run_timer() {
    driver.close_overdue_periods([&](const PeriodOutput& p) { published.push_back({p.frame_index, p.without_scan}); });
  }

  std::unique_ptr<InputDecoder> decoder = std::make_unique<InputDecoder>(kEpoch);
  test::RecordingPort port;
  PeriodDriver driver{*decoder, port};
  std::vector<Published> published;
  std::vector<Vec3f> points{Vec3f(5.0f, 0.0f, 1.0f), Vec3f(6.0f, 1.0f, 1.0f)};
  int can_frames_ = 0;
};

TEST_F(PeriodTimerDriver, ClosesAPeriodWithAnEmptyScanAtTheExpectedStampOnTheInputsClock) {
  scan_at(1.0);
  ASSERT_EQ(published.size(), 1u);
  for (const double t : {1.04, 1.09, 1.15, 1.25}) can_at(t);
  EXPECT_FALSE(driver.timer_due()) << "1.25 s is within the tolerance of the scan expected at 1.1 s";
  run_timer();
  EXPECT_EQ(published.size(), 1u);
  EXPECT_EQ(port.calls, "e");  // the vehicle frames are held
  can_at(1.26);
  ASSERT_TRUE(driver.timer_due());
  run_timer();
  ASSERT_EQ(published.size(), 2u);
  EXPECT_EQ(published[1].frame_index, 1u);
  EXPECT_TRUE(published[1].without_scan);
  // The inputs stamped up to the expected stamp went first, then the empty scan at that stamp.
  EXPECT_EQ(port.calls, "evve");
  ASSERT_EQ(port.scan_t.size(), 2u);
  EXPECT_DOUBLE_EQ(port.scan_t[1], 1.0 + PeriodTimerParams{}.period_s);
  EXPECT_EQ(port.scan_points[1], 0u);
  EXPECT_FALSE(driver.timer_due());
  EXPECT_EQ(driver.counters().periods, 2u);
  EXPECT_EQ(driver.counters().periods_without_scan, 1u);
}

TEST_F(PeriodTimerDriver, ALateScanIsCountedAndTheNextScanOpensTheFollowingPeriod) {
  scan_at(1.0);
  for (const double t : {1.09, 1.15, 1.26}) can_at(t);
  run_timer();
  ASSERT_EQ(published.size(), 2u);
  scan_at(1.1);  // the scan of the period the timer closed: not used, nothing published
  EXPECT_EQ(published.size(), 2u);
  EXPECT_EQ(driver.counters().late_scans, 1u);
  EXPECT_EQ(port.calls, "eve");
  scan_at(1.2);
  ASSERT_EQ(published.size(), 3u);
  EXPECT_EQ(published[2].frame_index, 2u);
  EXPECT_FALSE(published[2].without_scan);
  EXPECT_EQ(port.calls, "evevve");  // the held frames of 1.15 s and 1.26 s, then the scan
  EXPECT_EQ(port.scan_points.back(), points.size());
  EXPECT_EQ(driver.counters().periods, 3u);
}

TEST_F(PeriodTimerDriver, AScanAfterASilenceClosesTheSkippedPeriodsFirst) {
  scan_at(1.0);
  scan_at(1.3);  // no CAN input in between: the scan's stamp shows 1.1 s and 1.2 s passed
  ASSERT_EQ(published.size(), 4u);
  EXPECT_TRUE(published[1].without_scan);
  EXPECT_TRUE(published[2].without_scan);
  EXPECT_FALSE(published[3].without_scan);
  EXPECT_EQ(published[3].frame_index, 3u);
  ASSERT_EQ(port.scan_t.size(), 4u);
  EXPECT_NEAR(port.scan_t[1], 1.1, 1e-12);
  EXPECT_NEAR(port.scan_t[2], 1.2, 1e-12);
  EXPECT_DOUBLE_EQ(port.scan_t[3], 1.3);
  EXPECT_EQ(driver.counters().late_scans, 0u);
}

TEST_F(PeriodTimerDriver, NeverFiresWhileAScanClosesEveryPeriod) {
  for (int k = 0; k < 200; ++k) {  // 2 s: 100 Hz vehicle signals, a scan every 100 ms
    can_at(0.01 * k);
    run_timer();
    if (k % 10 == 0) scan_at(0.01 * k);
  }
  EXPECT_EQ(driver.counters().periods, 20u);
  EXPECT_EQ(driver.counters().periods_without_scan, 0u);
  for (std::size_t i = 0; i < published.size(); ++i) EXPECT_EQ(published[i].frame_index, i);
}

TEST_F(PeriodTimerDriver, AClockStepRestartsTheTimerInsteadOfClosingEveryPeriod) {
  scan_at(1.0);
  can_at(100.0);
  run_timer();
  const std::uint32_t cap = PeriodTimerParams{}.max_periods_per_input;
  EXPECT_EQ(driver.counters().periods_without_scan, cap);
  EXPECT_EQ(driver.counters().timer_restarts, 1u);
  can_at(100.1);
  EXPECT_FALSE(driver.timer_due()) << "expected again one period after the step";
}

// The firmware over scripted links: one ego scan, then 1 s of vehicle frames and V2X shares.
TEST(FirmwarePeriodTimer, PublishesEveryPeriodAndTheHeartbeatFlagsTheSilentLidar) {
  hal::SimClock clock(0, kEpoch);
  test::ScriptedCan can;
  can.clock = &clock;
  SimTimeCanBus sim_can(can, clock);
  test::ScriptedLink v2x, ego;
  auto decoder = std::make_unique<InputDecoder>(kEpoch);
  test::RecordingPort port;
  FirmwareApp app(FirmwareHal{sim_can, v2x, ego, clock, nullptr, nullptr}, *decoder, port);
  ASSERT_EQ(app.start(), hal::Status::kOk);
  can.queue.push_back(make_sim_time_frame(100'000'000));
  for (const auto& d : test::cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 100'000'000)) ego.queue.push_back(d);
  for (int k = 0; k < 10 && app.counters().frames_published == 0; ++k) app.poll_once();
  ASSERT_EQ(app.counters().frames_published, 1u);
  EXPECT_FALSE(app.heartbeat_now().lidar_timeout);

  for (int k = 1; k <= 100; ++k) {  // to 1.1 s; the timer closes 0.2 .. 0.9 s (0.9 + 0.155 < 1.1)
    const std::int64_t t = 100'000'000 + k * 10'000'000LL;
    can.queue.push_back(make_sim_time_frame(t));
    can.queue.push_back(vehicle_frame(k));
    if (k % 10 == 0) {
      for (const auto& d : test::cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, t, static_cast<std::uint32_t>(k))) v2x.queue.push_back(d);
    }
    app.poll_once();
  }
  EXPECT_EQ(app.period_counters().periods_without_scan, 8u);
  EXPECT_EQ(app.counters().frames_published, 9u);
  ASSERT_EQ(port.scan_points.size(), 9u);
  EXPECT_EQ(port.scan_points.back(), 0u);
  const protocol::Heartbeat silent = app.heartbeat_now();
  EXPECT_TRUE(silent.lidar_timeout);
  EXPECT_EQ(silent.error_flags & protocol::heartbeat_error::kUdpTimeout, 0) << "the shares keep the UDP alive";
  protocol::Heartbeat decoded;
  ASSERT_EQ(protocol::unpack(protocol::pack(silent), decoded), protocol::DecodeStatus::kOk);
  EXPECT_TRUE(decoded.lidar_timeout);

  // The LiDAR returns at 1.2 s: the periods of 1.0 and 1.1 s close first, then its own.
  can.queue.push_back(make_sim_time_frame(1'200'000'000));
  for (const auto& d : test::cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 1'200'000'000, 1)) ego.queue.push_back(d);
  for (int k = 0; k < 10 && app.counters().frames_published < 12; ++k) app.poll_once();
  EXPECT_EQ(app.counters().frames_published, 12u);
  EXPECT_EQ(app.period_counters().periods_without_scan, 10u);
  EXPECT_EQ(port.scan_points.back(), 600u);
  EXPECT_FALSE(app.heartbeat_now().lidar_timeout);
}

}  // namespace
}  // namespace v2xloc::firmware
