// The ego IMU of a recording (host_sim/sensors/imu.hpp) as the HID input reports the device sends
// (hal/HID_IMU_REPORT.md): counter, status (time-synced; saturation), sensor time = the Unix time
// in microseconds modulo 2^32 (the sensor follows the GNSS PPS), gyro, accel and temperature in
// the report's units. Each report reaches the host at the next 1-ms USB frame after its sample.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hal/emulated/hid_script.hpp"
#include "host_sim/sensors/imu.hpp"

namespace v2xloc::sim {

struct ImuReportStream {
  std::vector<hal::HidScriptLine> reports;   // receive time = ns of recording time
  std::vector<ImuMeasurement> measurements;  // the same samples before encoding (truth inside)
};

// Every sample in [0, duration) of body_to_enu, encoded; time_origin_unix_s gives the sensor time.
ImuReportStream simulate_imu_reports(const ImuConfig& config, std::uint64_t seed, const PoseAt& body_to_enu,
                                     double duration_s, double time_origin_unix_s);
// One measurement as report bytes (hal::hid_imu units, rounded and clamped to int16).
hal::HidScriptLine encode_imu_report(const ImuMeasurement& m, std::uint8_t counter, double time_origin_unix_s);
// The stream in the hid_script text form.
std::string imu_reports_text(const std::vector<hal::HidScriptLine>& reports);

}  // namespace v2xloc::sim
