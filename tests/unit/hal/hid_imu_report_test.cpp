#include "hal/hid_imu_report.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace v2xloc::hal::hid_imu {
namespace {

TEST(HidImuReport, RoundTripAndDocumentedByteOffsets) {
  RawReport r;
  r.counter = 200;
  r.status = status_bits::kTimeSynced;
  r.sensor_time_us = 0x01020304u;
  r.gyro[0] = -1;
  r.gyro[1] = 2;
  r.gyro[2] = -1234;  // -12.34 deg/s yaw rate
  r.accel[0] = 10;
  r.accel[1] = -20;
  r.accel[2] = 1000;  // 1 g
  r.temperature = 2550;
  std::array<std::uint8_t, kInputReportBytes> bytes{};
  ASSERT_EQ(encode_input_report(r, bytes), kInputReportBytes);
  EXPECT_EQ(bytes[0], kInputReportId);
  EXPECT_EQ(bytes[1], 200);
  EXPECT_EQ(bytes[4], 0x04);  // little-endian sensor time
  EXPECT_EQ(bytes[7], 0x01);
  EXPECT_EQ(bytes[12], 0x2E);  // gyro z = -1234 = 0xFB2E, low byte first
  EXPECT_EQ(bytes[13], 0xFB);
  RawReport back;
  ASSERT_EQ(decode_input_report(bytes, back), Status::kOk);
  EXPECT_EQ(back.gyro[2], -1234);
  EXPECT_EQ(back.accel[2], 1000);
  EXPECT_EQ(back.sensor_time_us, r.sensor_time_us);
  EXPECT_EQ(back.temperature, 2550);
  const Sample s = to_si(back);
  EXPECT_NEAR(s.gyro_rad_s[2], -12.34 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(s.accel_m_s2[2], 9.80665, 1e-12);
  EXPECT_NEAR(s.temperature_c, 25.5, 1e-12);
}

TEST(HidImuReport, WrongIdOrSizeIsMalformed) {
  std::array<std::uint8_t, kInputReportBytes> bytes{};
  RawReport r;
  EXPECT_EQ(decode_input_report(bytes, r), Status::kMalformed);  // id 0
  bytes[0] = kInputReportId;
  EXPECT_EQ(decode_input_report(std::span<const std::uint8_t>(bytes.data(), 21), r), Status::kMalformed);
  std::array<std::uint8_t, kOutputReportBytes> cmd{};
  ASSERT_EQ(encode_command(Command::kSetRate, 200, cmd), kOutputReportBytes);
  EXPECT_EQ(cmd[0], kOutputReportId);
  EXPECT_EQ(cmd[1], 1);
  EXPECT_EQ(cmd[2], 200);
  EXPECT_EQ(cmd[3], 0);
}

TEST(HidImuReport, DescriptorDeclaresTheReportSizes) {
  // Input report: id + Report Count(21) bytes; output report: id + Report Count(7) bytes.
  EXPECT_EQ(kReportDescriptor[19], kInputReportBytes - 1);
  EXPECT_EQ(kReportDescriptor[27], kOutputReportBytes - 1);
}

}  // namespace
}  // namespace v2xloc::hal::hid_imu
