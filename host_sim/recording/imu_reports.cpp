#include "host_sim/recording/imu_reports.hpp"

#include <algorithm>
#include <cmath>

#include "hal/hid_imu_report.hpp"

namespace v2xloc::sim {
namespace {

namespace hid = hal::hid_imu;

std::int16_t to_lsb(double value, double per_lsb) {
  return static_cast<std::int16_t>(std::clamp(std::nearbyint(value / per_lsb), -32767.0, 32767.0));
}

constexpr std::int64_t kUsbFrameNs = 1'000'000;

}  // namespace

hal::HidScriptLine encode_imu_report(const ImuMeasurement& m, std::uint8_t counter, double time_origin_unix_s) {
  hid::RawReport r;
  r.counter = counter;
  r.status = hid::status_bits::kTimeSynced;
  if (m.gyro_saturated) r.status |= hid::status_bits::kGyroSaturated;
  if (m.accel_saturated) r.status |= hid::status_bits::kAccelSaturated;
  const std::int64_t unix_us = std::llround(time_origin_unix_s * 1e6) + std::llround(m.t * 1e6);
  r.sensor_time_us = static_cast<std::uint32_t>(static_cast<std::uint64_t>(unix_us));
  constexpr double kDegPerRad = 180.0 / M_PI;
  for (int k = 0; k < 3; ++k) {
    r.gyro[k] = to_lsb(m.gyro[k] * kDegPerRad, hid::kGyroDegPerSecondPerLsb);
    r.accel[k] = to_lsb(m.accel[k] / hid::kStandardGravity, hid::kAccelGPerLsb);
  }
  r.temperature = to_lsb(m.temperature_c, hid::kTemperatureCPerLsb);
  hal::HidScriptLine line;
  line.size = static_cast<std::uint8_t>(hid::encode_input_report(r, line.bytes));
  // Picked up by the host at the next 1-ms USB frame.
  const std::int64_t t_ns = std::llround(m.t * 1e9);
  line.timestamp_ns = (t_ns / kUsbFrameNs + 1) * kUsbFrameNs;
  return line;
}

ImuReportStream simulate_imu_reports(const ImuConfig& config, std::uint64_t seed, const PoseAt& body_to_enu,
                                     double duration_s, double time_origin_unix_s) {
  ImuSimulator imu(config, seed);
  ImuReportStream out;
  std::uint8_t counter = 0;
  for (std::int64_t k = 0;; ++k) {
    const double t = imu.sample_time(k);
    if (t >= duration_s) break;
    out.measurements.push_back(imu.sample(body_to_enu, t));
    out.reports.push_back(encode_imu_report(out.measurements.back(), counter++, time_origin_unix_s));
  }
  return out;
}

std::string imu_reports_text(const std::vector<hal::HidScriptLine>& reports) {
  std::string text = "# receive_time_ns(recording time) HID input report bytes (hal/HID_IMU_REPORT.md)\n";
  char line[256];
  for (const hal::HidScriptLine& r : reports) {
    const std::size_t n = hal::format_hid_script_line(r.timestamp_ns, std::span<const std::uint8_t>(r.bytes.data(), r.size), line);
    text.append(line, n);
  }
  return text;
}

}  // namespace v2xloc::sim
