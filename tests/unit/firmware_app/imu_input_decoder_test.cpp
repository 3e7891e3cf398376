// HID IMU reports -> localizer samples (firmware/wire/imu_input_decoder.hpp): hostile reports
// (truncated, wrong id, counter jumps, repeats, late reports, time going back, the 32-bit
// microsecond wrap, implausible times) are counted and never reach the localizer; every report read
// lands in exactly one count; the period driver hands the samples on in time order before the
// period's map clouds and scan.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/localizer_port.hpp"
#include "firmware/wire/period_driver.hpp"
#include "firmware/protocol/can_messages.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "hal/hid_imu_report.hpp"

namespace v2xloc::firmware {
namespace {

namespace hid = hal::hid_imu;

constexpr std::int64_t kUs = 1000;
constexpr std::int64_t kPeriodUs = 5000;  // 200 Hz
// A Unix time in microseconds and the epoch of localizer time 0 (1 s before it).
constexpr std::int64_t kUnixUs0 = 1'700'000'000'000'000LL;
constexpr std::int64_t kEpochNs = (kUnixUs0 - 1'000'000) * kUs;

std::array<std::uint8_t, hid::kInputReportBytes> report(std::uint8_t counter, std::uint32_t sensor_us,
                                                        std::uint8_t status = hid::status_bits::kTimeSynced,
                                                        std::int16_t gyro_z = 100) {
  hid::RawReport r;
  r.counter = counter;
  r.status = status;
  r.sensor_time_us = sensor_us;
  r.gyro[2] = gyro_z;
  r.accel[2] = 1000;
  std::array<std::uint8_t, hid::kInputReportBytes> bytes{};
  hid::encode_input_report(r, bytes);
  return bytes;
}

// Synced report k of a 200 Hz stream starting at kUnixUs0, received 1 ms after its sample.
struct SyncedStream {
  ImuInputDecoder& decoder;
  ImuReportKind send(std::int64_t k, std::uint8_t counter, std::uint8_t status = hid::status_bits::kTimeSynced) {
    const std::int64_t unix_us = kUnixUs0 + k * kPeriodUs;
    return decoder.decode(report(counter, static_cast<std::uint32_t>(unix_us), status), (unix_us + 1000) * kUs);
  }
};

std::vector<ImuInput> drain(ImuInputDecoder& d) {
  std::vector<ImuInput> out;
  ImuInput s;
  while (d.take(s)) out.push_back(s);
  return out;
}

void expect_every_report_counted(const ImuCounters& c) { EXPECT_EQ(c.reports, c.samples + c.rejected()); }

TEST(ImuInputDecoder, SyncedReportsMapToTheInputsClockInOrder) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  for (int k = 0; k < 10; ++k) EXPECT_EQ(s.send(k, static_cast<std::uint8_t>(k)), ImuReportKind::kSample);
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), 10u);
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(got[k].t, localizer_time_s((kUnixUs0 + k * kPeriodUs) * kUs, kEpochNs));
    EXPECT_NEAR(got[k].gyro[2], 1.0 * M_PI / 180.0, 1e-12);  // 100 LSB = 1 deg/s
    EXPECT_NEAR(got[k].accel[2], hid::kStandardGravity, 1e-12);
    EXPECT_FALSE(got[k].saturated);
  }
  EXPECT_DOUBLE_EQ(got[0].t, 1.0);
  EXPECT_EQ(d->counters().lost, 0u);
  EXPECT_EQ(d->counters().handed, 10u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, MalformedReportsAreCountedAndNothingIsQueued) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  auto good = report(0, static_cast<std::uint32_t>(kUnixUs0));
  const std::int64_t rx = (kUnixUs0 + 1000) * kUs;
  EXPECT_EQ(d->decode(std::span<const std::uint8_t>(good.data(), good.size() - 1), rx), ImuReportKind::kMalformed);
  std::array<std::uint8_t, hid::kInputReportBytes + 1> longer{};
  std::copy(good.begin(), good.end(), longer.begin());
  EXPECT_EQ(d->decode(longer, rx), ImuReportKind::kMalformed);
  auto wrong_id = good;
  wrong_id[0] = hid::kOutputReportId;
  EXPECT_EQ(d->decode(wrong_id, rx), ImuReportKind::kMalformed);
  EXPECT_EQ(d->decode(std::span<const std::uint8_t>(), rx), ImuReportKind::kMalformed);
  EXPECT_EQ(d->pending(), 0u);
  EXPECT_EQ(d->decode(good, rx), ImuReportKind::kSample);  // the stream goes on
  EXPECT_EQ(d->counters().malformed, 4u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, CounterJumpsCountLostReportsAlsoPastTheCounterRange) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  s.send(0, 0);
  s.send(1, 1);
  s.send(5, 5);  // 2, 3, 4 lost
  EXPECT_EQ(d->counters().lost, 3u);
  s.send(6, 250);  // the counter jumped by 245 in one sample period: the counter says 244 lost
  EXPECT_EQ(d->counters().lost, 3u + 244u);
  // 300 periods of silence: the 8-bit counter wrapped (300 mod 256 = 44); the sensor time tells.
  s.send(306, static_cast<std::uint8_t>(250 + 300));
  EXPECT_EQ(d->counters().lost, 3u + 244u + 299u);
  EXPECT_EQ(drain(*d).size(), 5u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, RepeatedAndLateReportsAreDroppedAndCounted) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  s.send(0, 0);
  EXPECT_EQ(s.send(0, 0), ImuReportKind::kRepeated);
  s.send(2, 2);                                          // 1 is missing: lost
  EXPECT_EQ(s.send(1, 1), ImuReportKind::kOutOfOrder);  // arrives late: never handed on out of order
  s.send(3, 3);
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_LT(got[0].t, got[1].t);
  EXPECT_LT(got[1].t, got[2].t);
  EXPECT_EQ(d->counters().repeated, 1u);
  EXPECT_EQ(d->counters().out_of_order, 1u);
  EXPECT_EQ(d->counters().lost, 1u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, SensorTimeJumpingBackwardIsRefused) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  s.send(100, 0);
  s.send(101, 1);
  // Counter goes on but the sensor time is 0.4 s earlier (received now): refused, then recovered.
  const std::int64_t rx = (kUnixUs0 + 101 * kPeriodUs + 2000) * kUs;
  EXPECT_EQ(d->decode(report(2, static_cast<std::uint32_t>(kUnixUs0 + 21 * kPeriodUs)), rx), ImuReportKind::kOutOfOrder);
  EXPECT_EQ(s.send(103, 3), ImuReportKind::kSample);
  EXPECT_EQ(drain(*d).size(), 3u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, TheMicrosecondCounterWrapIsSeamless) {
  // Unix microseconds crossing a multiple of 2^32: the sensor time wraps to small values.
  const std::int64_t wrap_us = (kUnixUs0 / (1LL << 32) + 1) * (1LL << 32);
  auto d = std::make_unique<ImuInputDecoder>((wrap_us - 1'000'000) * kUs);
  for (int k = 0; k < 6; ++k) {
    const std::int64_t unix_us = wrap_us - 12'500 + k * kPeriodUs;
    EXPECT_EQ(d->decode(report(static_cast<std::uint8_t>(k), static_cast<std::uint32_t>(unix_us)), (unix_us + 1000) * kUs),
              ImuReportKind::kSample);
  }
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), 6u);
  for (int k = 1; k < 6; ++k) EXPECT_NEAR(got[k].t - got[k - 1].t, 0.005, 1e-9);
  EXPECT_NEAR(got[0].t, 1.0 - 0.0125, 1e-9);
  EXPECT_EQ(d->counters().lost, 0u);
}

TEST(ImuInputDecoder, UnsyncedTimeFollowsTheLeastDelayedReportAndUnwraps) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  const std::uint32_t sensor0 = 0xFFFFFFFFu - 7000;  // wraps after the second report
  const std::int64_t rx0 = (kUnixUs0 + 3000) * kUs;  // first report 3 ms late
  const std::int64_t delays_us[] = {3000, 1000, 2000, 1500};
  for (int k = 0; k < 4; ++k) {
    const std::uint32_t sensor = sensor0 + static_cast<std::uint32_t>(k * kPeriodUs);
    const std::int64_t rx = rx0 - 3000 * kUs + (k * kPeriodUs + delays_us[k]) * kUs;
    EXPECT_EQ(d->decode(report(static_cast<std::uint8_t>(k), sensor, 0), rx), ImuReportKind::kSample);
  }
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), 4u);
  // The first report defines the offset until the second (1 ms delay) lowers it by 2 ms.
  EXPECT_DOUBLE_EQ(got[0].t, localizer_time_s(rx0, kEpochNs));
  const double true0 = localizer_time_s(kUnixUs0 * kUs, kEpochNs);
  for (int k = 1; k < 4; ++k) EXPECT_NEAR(got[k].t, true0 + k * 0.005 + 0.001, 1e-9);
  EXPECT_EQ(d->counters().unsynced, 4u);
  EXPECT_EQ(d->counters().lost, 0u);
}

TEST(ImuInputDecoder, StatusBitsSelfTestRefusedSaturationFlagged) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  namespace bits = hid::status_bits;
  EXPECT_EQ(s.send(0, 0, bits::kTimeSynced | bits::kGyroSaturated), ImuReportKind::kSample);
  EXPECT_EQ(s.send(1, 1, bits::kTimeSynced | bits::kSelfTestFailed), ImuReportKind::kSelfTestFailed);
  EXPECT_EQ(s.send(2, 2, bits::kTimeSynced | bits::kAccelSaturated), ImuReportKind::kSample);
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(got[0].saturated);
  EXPECT_TRUE(got[1].saturated);
  EXPECT_EQ(d->counters().saturated, 2u);
  EXPECT_EQ(d->counters().self_test_failed, 1u);
  EXPECT_EQ(d->counters().lost, 0u);  // the refused report still advanced the counter
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, ImplausibleSampleTimesAreRejected) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  const std::int64_t rx = (kUnixUs0 + 10'000'000) * kUs;
  // 10 s before it was received (beyond max_latency), and 50 ms after it.
  EXPECT_EQ(d->decode(report(0, static_cast<std::uint32_t>(kUnixUs0)), rx), ImuReportKind::kTimeRejected);
  EXPECT_EQ(d->decode(report(1, static_cast<std::uint32_t>(kUnixUs0 + 10'050'000)), rx), ImuReportKind::kTimeRejected);
  EXPECT_EQ(d->decode(report(2, static_cast<std::uint32_t>(kUnixUs0 + 9'999'000)), rx), ImuReportKind::kSample);
  EXPECT_EQ(d->counters().time_rejected, 2u);
  expect_every_report_counted(d->counters());
}

TEST(ImuInputDecoder, AFullQueueDropsTheOldestAndCountsThem) {
  auto d = std::make_unique<ImuInputDecoder>(kEpochNs);
  SyncedStream s{*d};
  const std::size_t n = ImuInputDecoder::kMaxPendingSamples + 5;
  for (std::size_t k = 0; k < n; ++k) s.send(static_cast<std::int64_t>(k), static_cast<std::uint8_t>(k));
  EXPECT_EQ(d->counters().queue_dropped, 5u);
  const std::vector<ImuInput> got = drain(*d);
  ASSERT_EQ(got.size(), ImuInputDecoder::kMaxPendingSamples);
  EXPECT_DOUBLE_EQ(got.front().t, localizer_time_s((kUnixUs0 + 5 * kPeriodUs) * kUs, kEpochNs));
}

TEST(ImuInputDecoder, RefusesANonsenseRate) {
  ImuInputDecoder d;
  ImuDecoderConfig bad;
  bad.rate_hz = 0.0;
  EXPECT_FALSE(d.configure(bad));
  EXPECT_EQ(d.config().rate_hz, 200.0);
}

// Records the localizer calls in order: "i" IMU (with its time), "e" ego scan.
class CallLog final : public LocalizerPort {
 public:
  void on_vehicle(const VehicleInput&) override { calls += "v"; }
  void on_gnss(const GnssInput&) override { calls += "g"; }
  void on_imu(const ImuInput& s) override {
    calls += "i";
    times.push_back(s.t);
  }
  MapInsertResult on_map_cloud(const MapCloudInput&) override {
    calls += "m";
    return {};
  }
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput&) override {
    calls += "e";
    return output_;
  }
  std::string calls;
  std::vector<double> times;

 private:
  LocalizerFrameOutput output_{};
};

// A period driver over a call log, and the inputs the tests feed it.
class ImuPeriodDriver : public ::testing::Test {
 protected:
  void sample(int k, std::int64_t unix_us, std::int64_t latency_us) {
    driver.on_imu_report(report(static_cast<std::uint8_t>(k), static_cast<std::uint32_t>(unix_us)),
                         (unix_us + latency_us) * kUs);
  }
  void vehicle(std::size_t k, std::int64_t rx_unix_us) {
    protocol::VehicleMotion vm;
    vm.wheel_speed_mps = 5.0;
    vm.speed_valid = vm.yaw_rate_valid = true;
    vm.counter = static_cast<std::uint8_t>(k % protocol::kCounterModulo);
    driver.on_can(protocol::pack(vm), rx_unix_us * kUs);
  }
  void close(CloudKind kind) {
    DecodedCloud scan;
    scan.kind = kind;
    driver.close_period(scan, [](const PeriodOutput&) {});
  }
  std::unique_ptr<InputDecoder> decoder = std::make_unique<InputDecoder>(kEpochNs);
  CallLog log;
  PeriodDriver driver{*decoder, log};
};

TEST_F(ImuPeriodDriver, SamplesReachTheLocalizerAtThePeriodCloseInTimeOrder) {
  for (int k = 0; k < 3; ++k) sample(k, kUnixUs0 + k * kPeriodUs, 1000);
  EXPECT_EQ(log.calls, "");  // queued until the period closes
  close(CloudKind::kEgoScan);
  EXPECT_EQ(log.calls, "iiie");
  ASSERT_EQ(log.times.size(), 3u);
  EXPECT_LT(log.times[0], log.times[1]);
  EXPECT_LT(log.times[1], log.times[2]);
  EXPECT_EQ(driver.counters().imu_handed, 3u);
  // A refused scan still closes the period: the samples go on, no scan call.
  sample(3, kUnixUs0 + 3 * kPeriodUs, 1000);
  close(CloudKind::kEgoRejected);
  EXPECT_EQ(log.calls, "iiiei");
  EXPECT_EQ(decoder->imu().counters().handed, 4u);
}

// The period's vehicle signals are held and merged with the IMU samples by time, whatever order
// the two devices were read in: the filter fuses gyro and wheel in sequence.
TEST_F(ImuPeriodDriver, VehicleSignalsAndSamplesReachTheLocalizerInTimeOrder) {
  for (int k = 0; k < 3; ++k) {  // each vehicle frame 2.5 ms after the sample, and read before it
    const std::int64_t unix_us = kUnixUs0 + k * kPeriodUs;
    vehicle(static_cast<std::size_t>(k), unix_us + kPeriodUs / 2);
    sample(k, unix_us, 4000);
  }
  EXPECT_EQ(log.calls, "");  // held until the period closes
  close(CloudKind::kEgoScan);
  EXPECT_EQ(log.calls, "ivivive");
  EXPECT_EQ(driver.counters().imu_handed, 3u);
  EXPECT_EQ(driver.counters().inputs_released_early, 0u);
}

TEST_F(ImuPeriodDriver, AStalledPeriodReleasesItsHeldInputsEarlyAndCountsThem) {
  const std::size_t n = PendingInputs::kCapacity + 1;
  for (std::size_t k = 0; k < n; ++k) vehicle(k, kUnixUs0 + static_cast<std::int64_t>(k) * 10'000);
  EXPECT_EQ(log.calls, std::string(PendingInputs::kCapacity, 'v'));  // none lost, none waits forever
  EXPECT_EQ(driver.counters().inputs_released_early, PendingInputs::kCapacity);
  close(CloudKind::kEgoScan);
  EXPECT_EQ(log.calls, std::string(n, 'v') + "e");
}

}  // namespace
}  // namespace v2xloc::firmware
