// Report format of the USB HID IMU / yaw-rate sensor (spec: hal/HID_IMU_REPORT.md).
// Pure codec, allocation-free; little-endian byte-by-byte.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/status.hpp"

namespace v2xloc::hal::hid_imu {

inline constexpr std::uint16_t kVendorId = 0x1209;   // pid.codes open-source VID
inline constexpr std::uint16_t kProductId = 0x7A01;  // v2xloc IMU (test/bench id)
inline constexpr std::uint8_t kInputReportId = 0x01;
inline constexpr std::size_t kInputReportBytes = 22;  // including the report id byte
inline constexpr std::uint8_t kOutputReportId = 0x02;
inline constexpr std::size_t kOutputReportBytes = 8;

inline constexpr double kGyroDegPerSecondPerLsb = 0.01;   // +-327.67 deg/s
inline constexpr double kAccelGPerLsb = 0.001;            // +-32.767 g
inline constexpr double kTemperatureCPerLsb = 0.01;
inline constexpr double kStandardGravity = 9.80665;

namespace status_bits {
inline constexpr std::uint8_t kGyroSaturated = 1u << 0;
inline constexpr std::uint8_t kAccelSaturated = 1u << 1;
inline constexpr std::uint8_t kSelfTestFailed = 1u << 2;
inline constexpr std::uint8_t kTimeSynced = 1u << 3;  // sensor time follows the PPS
}  // namespace status_bits

struct RawReport {
  std::uint8_t counter = 0;        // +1 per report, wraps; gaps = lost reports
  std::uint8_t status = 0;         // status_bits
  std::uint32_t sensor_time_us = 0;
  std::int16_t gyro[3] = {0, 0, 0};   // x, y, z (z = yaw rate), body frame FLU
  std::int16_t accel[3] = {0, 0, 0};
  std::int16_t temperature = 0;
};

struct Sample {
  std::uint8_t counter = 0;
  std::uint8_t status = 0;
  std::uint32_t sensor_time_us = 0;
  double gyro_rad_s[3] = {0, 0, 0};
  double accel_m_s2[3] = {0, 0, 0};
  double temperature_c = 0;
};

enum class Command : std::uint8_t { kSetRate = 1, kZeroGyroBias = 2 };

std::size_t encode_input_report(const RawReport& report, std::span<std::uint8_t> out);
// kMalformed for a wrong size or report id.
Status decode_input_report(std::span<const std::uint8_t> bytes, RawReport& report);
Sample to_si(const RawReport& report);
std::size_t encode_command(Command command, std::uint16_t argument, std::span<std::uint8_t> out);

// Vendor-defined report descriptor: input report 1 (21 bytes), output report 2 (7 bytes).
inline constexpr std::array<std::uint8_t, 32> kReportDescriptor = {
    0x06, 0x00, 0xFF,  // Usage Page (Vendor Defined 0xFF00)
    0x09, 0x01,        // Usage (1)
    0xA1, 0x01,        // Collection (Application)
    0x85, 0x01,        //   Report ID (1)
    0x09, 0x02,        //   Usage (2)
    0x15, 0x00,        //   Logical Minimum (0)
    0x26, 0xFF, 0x00,  //   Logical Maximum (255)
    0x75, 0x08,        //   Report Size (8)
    0x95, 0x15,        //   Report Count (21)
    0x81, 0x02,        //   Input (Data, Var, Abs)
    0x85, 0x02,        //   Report ID (2)
    0x09, 0x03,        //   Usage (3)
    0x95, 0x07,        //   Report Count (7)
    0x91, 0x02,        //   Output (Data, Var, Abs)
    0xC0,              // End Collection
};

}  // namespace v2xloc::hal::hid_imu
