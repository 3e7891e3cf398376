#include "hal/hid_imu_report.hpp"

#include "hal/little_endian.hpp"

namespace v2xloc::hal::hid_imu {
namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

std::size_t encode_input_report(const RawReport& r, std::span<std::uint8_t> out) {
  if (out.size() < kInputReportBytes) return 0;
  std::uint8_t* p = out.data();
  p[0] = kInputReportId;
  p[1] = r.counter;
  p[2] = r.status;
  p[3] = 0;  // reserved
  le::put_u32(p + 4, r.sensor_time_us);
  for (int i = 0; i < 3; ++i) le::put_u16(p + 8 + 2 * i, static_cast<std::uint16_t>(r.gyro[i]));
  for (int i = 0; i < 3; ++i) le::put_u16(p + 14 + 2 * i, static_cast<std::uint16_t>(r.accel[i]));
  le::put_u16(p + 20, static_cast<std::uint16_t>(r.temperature));
  return kInputReportBytes;
}

Status decode_input_report(std::span<const std::uint8_t> bytes, RawReport& r) {
  if (bytes.size() != kInputReportBytes || bytes[0] != kInputReportId) return Status::kMalformed;
  const std::uint8_t* p = bytes.data();
  r.counter = p[1];
  r.status = p[2];
  r.sensor_time_us = le::get_u32(p + 4);
  for (int i = 0; i < 3; ++i) r.gyro[i] = static_cast<std::int16_t>(le::get_u16(p + 8 + 2 * i));
  for (int i = 0; i < 3; ++i) r.accel[i] = static_cast<std::int16_t>(le::get_u16(p + 14 + 2 * i));
  r.temperature = static_cast<std::int16_t>(le::get_u16(p + 20));
  return Status::kOk;
}

Sample to_si(const RawReport& r) {
  Sample s;
  s.counter = r.counter;
  s.status = r.status;
  s.sensor_time_us = r.sensor_time_us;
  for (int i = 0; i < 3; ++i) {
    s.gyro_rad_s[i] = r.gyro[i] * kGyroDegPerSecondPerLsb * (kPi / 180.0);
    s.accel_m_s2[i] = r.accel[i] * kAccelGPerLsb * kStandardGravity;
  }
  s.temperature_c = r.temperature * kTemperatureCPerLsb;
  return s;
}

std::size_t encode_command(Command command, std::uint16_t argument, std::span<std::uint8_t> out) {
  if (out.size() < kOutputReportBytes) return 0;
  out[0] = kOutputReportId;
  out[1] = static_cast<std::uint8_t>(command);
  le::put_u16(out.data() + 2, argument);
  for (std::size_t i = 4; i < kOutputReportBytes; ++i) out[i] = 0;
  return kOutputReportBytes;
}

}  // namespace v2xloc::hal::hid_imu
