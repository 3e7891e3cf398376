// The IMU's samples on their way into the filter (PX4 EKF2's IMU down-sampler): each sample is
// checked (finite, not saturated, after the previous one, not ahead of the other inputs by more
// than ImuParams::max_lead), watched for a stuck axis (the same value stuck_samples times in a
// row: a live MEMS axis's noise spans many LSBs), and its gyro z is integrated over fuse_period into
// one filter measurement (the mean rate over the span since the previous one: trapezoids between
// the samples, which are point samples of the rate; their plain mean would be the rate half a
// sample interval later, turning the yaw ahead by that much of each change of rate). A silence longer
// than max_gap is a dropout: the average restarts at the next sample. Every refusal is counted in
// LocalizerCounters. The last kImuRecentSamples gyro z samples are kept for the sweep's deskew.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc {

// A gyro z measurement for the filter: the mean rate over [t - span, t].
struct GyroMeasurement {
  bool ready = false;
  double t = 0.0;     // [s]
  double rate = 0.0;  // [rad/s]
  double span = 0.0;  // [s]
};

// One accepted gyro z sample (the deskew's yaw profile).
struct GyroSample {
  double t = 0.0;     // [s]
  double rate = 0.0;  // [rad/s] raw, bias not removed
};

class ImuIntake {
 public:
  static constexpr std::size_t kImuRecentSamples = 64;  // 0.32 s at 200 Hz: a 0.1 s sweep and its margins

  void configure(const ImuParams& params);
  // latest_input_t: the latest stamp of the other inputs (vehicle, GNSS, scans); has_input false
  // before the first one (no time-jump check then).
  GyroMeasurement push(const ImuInput& in, bool has_input, double latest_input_t, LocalizerCounters& counters);
  // A usable gyro sample arrived within max_gap before t.
  bool live(double t) const { return have_live_ && t - last_live_t_ <= params_.max_gap; }
  // Mean raw gyro z [rad/s] of the samples in (t - window, t], if at least two and the newest within
  // max_gap of t (the deskew's yaw rate); false otherwise.
  bool mean_rate(double t, double window, double& rate) const;
  // Raw gyro z [rad/s] extrapolated to `ahead` seconds after t along its trend: the mean over
  // (t - window, t] plus the change from the same mean trend_span earlier, per second, times
  // ahead + window / 2 (the mean's own age). False when either mean is missing.
  bool rate_ahead(double t, double window, double trend_span, double ahead, double& rate) const;
  // The accepted gyro z samples, oldest first, at most kImuRecentSamples, contiguous in time (a
  // dropout or a stuck axis clears them).
  std::span<const GyroSample> recent() const { return {recent_ + recent_first_, recent_count_}; }

 private:
  void watch_axes(const ImuInput& in, LocalizerCounters& counters);
  void remember(double t, double rate);

  ImuParams params_{};
  bool have_last_ = false;
  double last_t_ = 0.0;
  bool have_live_ = false;
  double last_live_t_ = 0.0;
  double previous_[6] = {0, 0, 0, 0, 0, 0};  // gyro x, y, z, accel x, y, z of the last sample
  std::uint32_t same_[6] = {0, 0, 0, 0, 0, 0};  // repeats of that value in a row
  bool anchored_ = false;  // the mean's span starts at anchor_t_
  double anchor_t_ = 0.0;
  double integral_ = 0.0;  // [rad] gyro z integrated since anchor_t_
  GyroSample previous_sample_{};
  GyroSample recent_[2 * kImuRecentSamples];  // a window slid by copying back when it reaches the end
  std::size_t recent_first_ = 0;
  std::size_t recent_count_ = 0;
};

}  // namespace v2xloc
