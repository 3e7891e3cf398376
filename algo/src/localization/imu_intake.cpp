#include "v2xloc/algo/localization/imu_intake.hpp"

#include <cmath>

namespace v2xloc {

void ImuIntake::configure(const ImuParams& params) {
  *this = ImuIntake{};
  params_ = params;
}

GyroMeasurement ImuIntake::push(const ImuInput& in, bool has_input, double latest_input_t,
                                LocalizerCounters& counters) {
  GyroMeasurement out;
  bool finite = std::isfinite(in.t);
  for (int i = 0; i < 3; ++i) finite = finite && std::isfinite(in.gyro[i]) && std::isfinite(in.accel[i]);
  if (!finite || in.saturated) {
    ++counters.imu_invalid;
    return out;
  }
  if (have_last_ && !(in.t > last_t_)) {
    ++counters.imu_out_of_order;
    return out;
  }
  if (has_input && in.t > latest_input_t + params_.max_lead) {
    ++counters.imu_time_jumps;
    return out;
  }
  if (have_last_ && in.t - last_t_ > params_.max_gap) {
    ++counters.imu_gaps;  // a dropout: the mean and the deskew's samples restart here
    anchored_ = false;
    recent_count_ = 0;
  }
  have_last_ = true;
  last_t_ = in.t;
  watch_axes(in, counters);
  if (params_.stuck_samples > 0 && same_[2] + 1 >= params_.stuck_samples) {
    anchored_ = false;  // gyro z stuck: not a measurement
    recent_count_ = 0;
    return out;
  }
  have_live_ = true;
  last_live_t_ = in.t;
  remember(in.t, in.gyro[2]);
  if (!anchored_) {  // the first sample after a start or a dropout opens the span
    anchored_ = true;
    anchor_t_ = in.t;
    integral_ = 0.0;
    previous_sample_ = {in.t, in.gyro[2]};
    return out;
  }
  integral_ += 0.5 * (previous_sample_.rate + in.gyro[2]) * (in.t - previous_sample_.t);
  previous_sample_ = {in.t, in.gyro[2]};
  const double span = in.t - anchor_t_;
  // 1 % slack: sensor-time stamps jitter, two 5 ms intervals may sum to just under 10 ms.
  if (span >= 0.99 * params_.fuse_period) {
    out = {true, in.t, integral_ / span, span};
    anchor_t_ = in.t;
    integral_ = 0.0;
  }
  return out;
}

// Counts the repeats of each axis's value; the stuck_samples-th repeat is a stuck episode.
void ImuIntake::watch_axes(const ImuInput& in, LocalizerCounters& counters) {
  const double v[6] = {in.gyro[0], in.gyro[1], in.gyro[2], in.accel[0], in.accel[1], in.accel[2]};
  for (int k = 0; k < 6; ++k) {
    same_[k] = v[k] == previous_[k] ? same_[k] + 1 : 0;
    previous_[k] = v[k];
    if (params_.stuck_samples > 0 && same_[k] + 1 == params_.stuck_samples) ++counters.imu_stuck_axes;
  }
}

bool ImuIntake::mean_rate(double t, double window, double& rate) const {
  const std::span<const GyroSample> r = recent();
  if (!(window > 0.0) || r.empty() || t - r.back().t > params_.max_gap) return false;
  double sum = 0.0;
  std::uint32_t n = 0;
  for (std::size_t i = r.size(); i > 0 && r[i - 1].t > t - window; --i) {
    if (r[i - 1].t > t) continue;
    sum += r[i - 1].rate;
    ++n;
  }
  if (n < 2) return false;
  rate = sum / n;
  return true;
}

bool ImuIntake::rate_ahead(double t, double window, double trend_span, double ahead, double& rate) const {
  double now = 0.0, before = 0.0;
  if (!(trend_span > 0.0) || !mean_rate(t, window, now) || !mean_rate(t - trend_span, window, before)) return false;
  rate = now + (now - before) / trend_span * (ahead + 0.5 * window);
  return true;
}

void ImuIntake::remember(double t, double rate) {
  if (recent_count_ == 0) recent_first_ = 0;
  if (recent_first_ + recent_count_ == 2 * kImuRecentSamples) {  // slide the window back to the start
    for (std::size_t i = 0; i < recent_count_; ++i) recent_[i] = recent_[recent_first_ + i];
    recent_first_ = 0;
  }
  recent_[recent_first_ + recent_count_] = {t, rate};
  if (recent_count_ < kImuRecentSamples) {
    ++recent_count_;
  } else {
    ++recent_first_;
  }
}

}  // namespace v2xloc
