// The period timer on the inputs' clock (period_driver.hpp): a localization period is expected to
// end with an ego scan one LiDAR period after the last one; when the inputs show that scan is not
// coming, the driver closes the period without it, stamped at the expected time, so the localizer
// predicts and a pose goes out every period whatever the LiDAR does.
// Time is the inputs' own (localizer seconds from CAN receive stamps and scan stamps, never a wall
// clock), so a replay closes the same periods on every run. Pure bookkeeping: the replayer runs the
// same rule on the events it sends to know which one makes the firmware publish (host_sim/replay).
#pragma once

#include <cstdint>

#include "v2xloc/algo/localization/localizer_params.hpp"

namespace v2xloc::firmware {

struct PeriodTimerParams {
  double period_s = ScanPreparationParams{}.frame_period;  // [s] ego LiDAR period (the localizer's)
  // [s] an input stamped this long after the expected scan's stamp shows it is not coming: a scan
  // completes one sweep after its stamp, plus transport (off the CAN grid of 10 ms steps)
  double tolerance_s = 0.155;
  // [periods] closed for one input at most; a larger step of the inputs' clock (a clock fault)
  // restarts the expectation at that input instead (counted)
  std::uint32_t max_periods_per_input = 10;
};

class PeriodTimer {
 public:
  explicit PeriodTimer(const PeriodTimerParams& params = {}) : params_(params) {}
  void configure(const PeriodTimerParams& params) { params_ = params; }
  const PeriodTimerParams& params() const { return params_; }

  // Running once the first scan closed a period (before it there is nothing to predict from).
  bool running() const { return running_; }
  // The stamp the next period's scan is expected at.
  double expected() const { return last_ + params_.period_s; }

  // A CAN input stamped t (the inputs' clock; it never goes back).
  void on_input(double t) {
    if (!have_input_ || t > input_t_) {
      input_t_ = t;
      closed_for_input_ = 0;
    }
    have_input_ = true;
  }
  // The latest input is stamped past the expected scan's stamp plus the tolerance.
  bool due() const { return running_ && have_input_ && input_t_ > expected() + params_.tolerance_s; }
  // The next period to close without a scan for the latest input: true and its stamp in t (the
  // period counts as closed). Past max_periods_per_input: restarts at the input, false.
  bool next_due(double& t) { return due() && take(input_t_, t); }

  // A scan stamped scan_t arrived (before next_skipped / late / closed_by_scan).
  void on_scan() { closed_for_input_ = 0; }
  // The scan belongs to a later period than the expected one (the nearest expected stamp): the
  // expected one passed without a scan; true and its stamp in t, as next_due.
  bool next_skipped(double scan_t, double& t) {
    return running_ && scan_t > expected() + 0.5 * params_.period_s && take(scan_t - params_.period_s, t);
  }
  // The scan belongs to the period the timer already closed (or an earlier one): late, not used.
  bool late(double scan_t) const { return running_ && !last_by_scan_ && !(scan_t > last_ + 0.5 * params_.period_s); }
  // The scan stamped t closed its period.
  void closed_by_scan(double t) { close(t, true); }
  // A scan refused for its stamp closed a period: it stands for the expected one.
  void closed_by_refused_scan() {
    if (running_) close(expected(), true);
  }

  std::uint64_t restarts() const { return restarts_; }

 private:
  bool take(double restart_t, double& t) {
    if (closed_for_input_ >= params_.max_periods_per_input) {
      close(restart_t, true);
      ++restarts_;
      return false;
    }
    ++closed_for_input_;
    t = expected();
    close(t, false);
    return true;
  }
  void close(double t, bool by_scan) {
    running_ = true;
    last_ = t;
    last_by_scan_ = by_scan;
  }

  PeriodTimerParams params_;
  bool running_ = false;
  double last_ = 0.0;          // [s] stamp of the last closed period
  bool last_by_scan_ = false;  // the last period was closed by a scan
  bool have_input_ = false;
  double input_t_ = 0.0;       // [s] latest input stamp
  std::uint32_t closed_for_input_ = 0;  // periods closed without a scan since the latest input or scan
  std::uint64_t restarts_ = 0;
};

}  // namespace v2xloc::firmware
