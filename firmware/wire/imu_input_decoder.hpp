// USB HID IMU input reports (hal/HID_IMU_REPORT.md) -> localizer ImuInput samples, queued until the
// period driver hands them on (period_driver.hpp: at the period's close, oldest first).
//
// Checks, each counted, never silent:
//   malformed      wrong size or report id (hal::hid_imu::decode_input_report);
//   self-test      status bit2 set: the sample is not handed on;
//   lost           counter gaps; a gap longer than the 8-bit counter (>= 128 report periods of
//                  sensor time) is counted from the sensor time at the nominal rate instead;
//   repeated       the same counter and sensor time again (a transport repeat): dropped;
//   out of order   a sample not after the last one handed on: dropped (its counter was counted
//                  lost when the gap appeared: a report is never handed on twice or late);
//   time rejected  a sample time more than max_latency before its receive time, or after it;
//   saturated      status bit0/bit1: handed on with ImuInput::saturated (the localizer decides);
//   queue dropped  more samples waiting than the queue holds (no period closed for
//                  kMaxPendingSamples report periods): the oldest are dropped.
//
// Time (the rule; localizer time = localizer_time_s(disciplined ns, epoch)):
//   time-synced reports (status bit3): sensor_time_us is the disciplined clock's Unix time in
//     microseconds modulo 2^32 (the sensor follows the GNSS PPS); the sample time is the value
//     congruent to it that lies nearest the report's receive time (unique within +-35.8 min, so
//     the 71.6-min wrap of the counter is harmless);
//   unsynced reports: the sensor time is unwrapped (signed 32-bit steps) into a 64-bit count and
//     mapped with offset = min over the reports since the anchor of (receive time - sensor time):
//     the report with the least transport delay fixes the offset. A change of the sync bit or a
//     sensor-time step of more than kReanchorGapUs (a sensor reset) starts a new anchor.
// Receive times are the HID backend's stamps on the disciplined clock.
// Allocation-free, no I/O.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

enum class ImuReportKind : std::uint8_t {
  kSample,         // queued for the localizer
  kMalformed,
  kSelfTestFailed,
  kRepeated,
  kOutOfOrder,
  kTimeRejected,
};

struct ImuCounters {
  std::uint64_t reports = 0;          // read from the device (every one lands in exactly one below)
  std::uint64_t samples = 0;          // decoded and queued for the localizer
  std::uint64_t malformed = 0;
  std::uint64_t self_test_failed = 0;
  std::uint64_t repeated = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t time_rejected = 0;
  std::uint64_t lost = 0;             // reports the sensor sent that never arrived in order
  std::uint64_t saturated = 0;        // of the samples: flagged saturated
  std::uint64_t unsynced = 0;         // of the samples: time by the offset estimate, not the PPS
  std::uint64_t queue_dropped = 0;    // samples dropped from a full queue (oldest first)
  std::uint64_t handed = 0;           // samples taken by the period driver
  std::uint64_t rejected() const { return malformed + self_test_failed + repeated + out_of_order + time_rejected; }
};

struct ImuDecoderConfig {
  double rate_hz = 200.0;                    // the sensor's configured output rate
  std::int64_t max_latency_ns = 500'000'000; // sample time at most this before its receive time
};

class ImuInputDecoder {
 public:
  static constexpr std::size_t kMaxPendingSamples = 1024;  // 5.1 s at 200 Hz
  static constexpr std::int64_t kReanchorGapUs = 10'000'000;

  explicit ImuInputDecoder(std::int64_t epoch_ns = 0) : epoch_ns_(epoch_ns) {}
  void set_epoch_ns(std::int64_t epoch_ns) { epoch_ns_ = epoch_ns; }
  // A rate outside 1..10000 Hz keeps the previous configuration (false).
  bool configure(const ImuDecoderConfig& config) {
    if (!(config.rate_hz >= 1.0 && config.rate_hz <= 10000.0) || config.max_latency_ns <= 0) return false;
    config_ = config;
    return true;
  }
  const ImuDecoderConfig& config() const { return config_; }

  // One report as read from the device, received at disciplined time rx_time_ns.
  ImuReportKind decode(std::span<const std::uint8_t> report, std::int64_t rx_time_ns);
  // The oldest queued sample; false when none is waiting.
  bool take(ImuInput& sample);
  // The oldest queued sample without taking it; null when none is waiting.
  const ImuInput* peek() const { return count_ == 0 ? nullptr : &queue_[head_]; }
  std::size_t pending() const { return count_; }

  const ImuCounters& counters() const { return counters_; }

 private:
  // Sample time on the disciplined clock [ns]; false when the time is implausible.
  bool sample_time_ns(std::uint32_t sensor_time_us, bool synced, std::int64_t rx_time_ns, std::int64_t& out);
  std::int64_t unsynced_time_ns(std::uint32_t sensor_time_us, std::int64_t rx_time_ns);
  // Reports the counter (or, for long gaps, the sensor time) says were lost before this one.
  std::uint64_t lost_before(std::uint8_t counter, std::int64_t time_ns) const;
  void push(const ImuInput& sample);

  std::int64_t epoch_ns_ = 0;
  ImuDecoderConfig config_{};
  ImuCounters counters_{};
  // The last sample queued.
  bool have_last_ = false;
  std::uint8_t last_counter_ = 0;
  std::uint32_t last_sensor_us_ = 0;
  bool last_synced_ = false;
  std::int64_t last_time_ns_ = 0;
  // Unsynced time base.
  bool anchored_ = false;
  std::uint32_t anchor_sensor_us_ = 0;
  std::int64_t anchor_unwrapped_us_ = 0;
  std::int64_t offset_ns_ = 0;
  // FIFO ring of samples waiting for the period driver.
  std::array<ImuInput, kMaxPendingSamples> queue_{};
  std::size_t head_ = 0, count_ = 0;
};

}  // namespace v2xloc::firmware
