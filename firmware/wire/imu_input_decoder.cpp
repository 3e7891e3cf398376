#include "firmware/wire/imu_input_decoder.hpp"

#include <cmath>

#include "firmware/wire/wire_conventions.hpp"
#include "hal/hid_imu_report.hpp"

namespace v2xloc::firmware {
namespace {

namespace bits = hal::hid_imu::status_bits;

// A sample may be stamped slightly after its receive time by the discipline of two clocks.
constexpr std::int64_t kFutureToleranceNs = 2'000'000;

}  // namespace

ImuReportKind ImuInputDecoder::decode(std::span<const std::uint8_t> report, std::int64_t rx_time_ns) {
  ++counters_.reports;
  hal::hid_imu::RawReport raw;
  if (hal::hid_imu::decode_input_report(report, raw) != hal::Status::kOk) {
    ++counters_.malformed;
    return ImuReportKind::kMalformed;
  }
  const bool synced = (raw.status & bits::kTimeSynced) != 0;
  if (have_last_ && raw.counter == last_counter_ && raw.sensor_time_us == last_sensor_us_ && synced == last_synced_) {
    ++counters_.repeated;
    return ImuReportKind::kRepeated;
  }
  std::int64_t t_ns = 0;
  if (!sample_time_ns(raw.sensor_time_us, synced, rx_time_ns, t_ns)) {
    ++counters_.time_rejected;
    return ImuReportKind::kTimeRejected;
  }
  if (have_last_ && t_ns <= last_time_ns_) {
    ++counters_.out_of_order;
    return ImuReportKind::kOutOfOrder;
  }
  counters_.lost += lost_before(raw.counter, t_ns);
  have_last_ = true;
  last_counter_ = raw.counter;
  last_sensor_us_ = raw.sensor_time_us;
  last_synced_ = synced;
  last_time_ns_ = t_ns;
  if ((raw.status & bits::kSelfTestFailed) != 0) {
    ++counters_.self_test_failed;
    return ImuReportKind::kSelfTestFailed;
  }
  const hal::hid_imu::Sample si = hal::hid_imu::to_si(raw);
  ImuInput sample;
  sample.t = localizer_time_s(t_ns, epoch_ns_);
  for (int k = 0; k < 3; ++k) {
    sample.gyro[k] = si.gyro_rad_s[k];
    sample.accel[k] = si.accel_m_s2[k];
  }
  sample.saturated = (raw.status & (bits::kGyroSaturated | bits::kAccelSaturated)) != 0;
  if (sample.saturated) ++counters_.saturated;
  if (!synced) ++counters_.unsynced;
  ++counters_.samples;
  push(sample);
  return ImuReportKind::kSample;
}

bool ImuInputDecoder::sample_time_ns(std::uint32_t sensor_time_us, bool synced, std::int64_t rx_time_ns,
                                     std::int64_t& out) {
  if (synced) {
    anchored_ = false;  // the unsynced base restarts after a spell of sync
    // The value congruent to sensor_time_us (mod 2^32 us) nearest the receive time.
    const std::int64_t rx_us = rx_time_ns >= 0 ? rx_time_ns / 1000 : -((-rx_time_ns + 999) / 1000);
    const auto step = static_cast<std::int32_t>(sensor_time_us - static_cast<std::uint32_t>(rx_us));
    out = (rx_us + step) * 1000;
  } else {
    out = unsynced_time_ns(sensor_time_us, rx_time_ns);
  }
  return out <= rx_time_ns + kFutureToleranceNs && out >= rx_time_ns - config_.max_latency_ns;
}

std::int64_t ImuInputDecoder::unsynced_time_ns(std::uint32_t sensor_time_us, std::int64_t rx_time_ns) {
  const auto step = static_cast<std::int32_t>(sensor_time_us - anchor_sensor_us_);
  if (!anchored_ || step > kReanchorGapUs || step < -kReanchorGapUs) {
    anchored_ = true;
    anchor_sensor_us_ = sensor_time_us;
    anchor_unwrapped_us_ = 0;
    offset_ns_ = rx_time_ns;
    return rx_time_ns;
  }
  const std::int64_t unwrapped_us = anchor_unwrapped_us_ + step;
  if (step > 0) {  // a late report does not move the base
    anchor_sensor_us_ = sensor_time_us;
    anchor_unwrapped_us_ = unwrapped_us;
  }
  const std::int64_t offset = rx_time_ns - unwrapped_us * 1000;
  if (offset < offset_ns_) offset_ns_ = offset;
  return unwrapped_us * 1000 + offset_ns_;
}

std::uint64_t ImuInputDecoder::lost_before(std::uint8_t counter, std::int64_t time_ns) const {
  if (!have_last_) return 0;
  const auto counted = static_cast<std::uint8_t>(counter - last_counter_);
  const double period_ns = 1e9 / config_.rate_hz;
  const double periods = std::nearbyint(static_cast<double>(time_ns - last_time_ns_) / period_ns);
  if (periods >= 128.0) return static_cast<std::uint64_t>(periods) - 1;  // longer than the counter can tell
  return counted > 0 ? counted - 1u : 0u;
}

void ImuInputDecoder::push(const ImuInput& sample) {
  if (count_ == kMaxPendingSamples) {
    head_ = (head_ + 1) % kMaxPendingSamples;
    --count_;
    ++counters_.queue_dropped;
  }
  queue_[(head_ + count_) % kMaxPendingSamples] = sample;
  ++count_;
}

bool ImuInputDecoder::take(ImuInput& sample) {
  if (count_ == 0) return false;
  sample = queue_[head_];
  head_ = (head_ + 1) % kMaxPendingSamples;
  --count_;
  ++counters_.handed;
  return true;
}

}  // namespace v2xloc::firmware
