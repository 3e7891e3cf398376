// IMU faults on a recording's HID report stream (v2xloc-replay / v2xloc-eval --faults, keys
// below; fault_injection.hpp parses them). Sensor faults alter the report contents, transport
// faults the stream; times are the reports' receive times in recording seconds.
//   imu-dropout=S       reports lost for S seconds from imu-dropout-at (default 1.0)
//   imu-stuck=AXIS      gx gy gz ax ay az: that axis repeats its value at imu-stuck-at (default 1.0)
//   imu-bias-step=DPS   gyro z (yaw rate) offset by DPS deg/s from imu-bias-step-at (default 1.0)
//   imu-repeat=P        each report delivered twice with probability P (transport)
//   imu-reorder=P       each report delivered after the next one (both at the next one's arrival)
//                       with probability P (transport)
// Seeded from the fault seed on a stream of its own: the other faults draw as without them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/emulated/hid_script.hpp"

namespace v2xloc::sim::replay {

struct ImuFaultSpec {
  double dropout_s = 0.0, dropout_at_s = 1.0;
  int stuck_axis = -1;  // 0..2 gyro x y z, 3..5 accel x y z; -1 none
  double stuck_at_s = 1.0;
  double bias_step_dps = 0.0, bias_step_at_s = 1.0;
  double repeat = 0.0, reorder = 0.0;
  bool any() const {
    return dropout_s > 0 || stuck_axis >= 0 || bias_step_dps != 0 || repeat > 0 || reorder > 0;
  }
};

struct ImuFaultStats {
  std::uint64_t dropped = 0, stuck = 0, biased = 0, repeated = 0, reordered = 0;
};

// A fault value: the whole text is a number within [lo, hi] (false otherwise, `out` unchanged).
bool parse_fault_number(const std::string& text, double lo, double hi, double& out);
// True when `key` is an IMU fault key (then ok says whether its value parsed).
bool parse_imu_fault(const std::string& key, const std::string& value, ImuFaultSpec& spec, bool& ok);
std::string describe(const ImuFaultSpec& spec);
// Applies every IMU fault of `spec` to `reports` (arrival times stay in order).
void apply_imu_faults(const ImuFaultSpec& spec, std::uint64_t seed, std::vector<hal::HidScriptLine>& reports,
                      ImuFaultStats& stats);

}  // namespace v2xloc::sim::replay
