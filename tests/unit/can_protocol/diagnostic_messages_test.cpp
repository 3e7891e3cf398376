// Diagnostic frames 0x210..0x214 (registration, gate decision, odometry): round trips at the
// signal resolution and saturation that clamps AND flags (never a wrapped value). CRC, DLC and id
// rejection of every message: CanMessages.EveryMessageIsCrcProtectedAndLeavesItsOutputUntouchedOnRejection.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "firmware/protocol/can_messages.hpp"

namespace v2xloc::protocol {
namespace {

TEST(DiagnosticMessages, RoundTripAtTheSignalResolution) {
  RegistrationPosition rp{-1234.5674, 8000.0016, true, true, false, 5}, rp2;
  ASSERT_EQ(unpack(pack(rp), rp2), DecodeStatus::kOk);
  EXPECT_NEAR(rp2.x_m, rp.x_m, 5e-4);
  EXPECT_NEAR(rp2.y_m, rp.y_m, 5e-4);
  EXPECT_TRUE(rp2.attempted && rp2.ok);
  EXPECT_FALSE(rp2.clamped);
  EXPECT_EQ(rp2.counter, 5);

  RegistrationQuality rq{-1.2345, 0.8765, 0.0421, 40000, 15}, rq2;
  ASSERT_EQ(unpack(pack(rq), rq2), DecodeStatus::kOk);
  EXPECT_NEAR(rq2.z_m, rq.z_m, 5e-4);
  EXPECT_NEAR(rq2.fitness, rq.fitness, 5e-4);
  EXPECT_NEAR(rq2.inlier_rmse_m, rq.inlier_rmse_m, 5e-4);
  EXPECT_EQ(rq2.frame_counter, 40000);
  EXPECT_EQ(rq2.counter, 15);

  GateDecision gd{65530, 65535, true, false, LocalizerModeCode::kTracking, true, 2}, gd2;
  ASSERT_EQ(unpack(pack(gd), gd2), DecodeStatus::kOk);
  EXPECT_EQ(gd2.decided_frame, 65530);
  EXPECT_EQ(gd2.frame_counter, 65535);
  EXPECT_TRUE(gd2.decided);
  EXPECT_FALSE(gd2.valid);
  EXPECT_EQ(gd2.mode, LocalizerModeCode::kTracking);
  EXPECT_TRUE(gd2.filter_initialized);
  EXPECT_EQ(gd2.counter, 2);

  OdometryPosition op{-0.0004, 7654.3216, true, false, 9}, op2;
  ASSERT_EQ(unpack(pack(op), op2), DecodeStatus::kOk);
  EXPECT_NEAR(op2.x_m, op.x_m, 5e-4);
  EXPECT_NEAR(op2.y_m, op.y_m, 5e-4);
  EXPECT_TRUE(op2.odometry_ok);
  EXPECT_FALSE(op2.clamped);

  OdometryAttitude oa{-1.9, 3.0, 123, true, false, 11}, oa2;
  ASSERT_EQ(unpack(pack(oa), oa2), DecodeStatus::kOk);
  EXPECT_NEAR(oa2.z_m, -1.9, 5e-4);
  EXPECT_NEAR(oa2.yaw_rad, 3.0, 5e-5);
  EXPECT_EQ(oa2.frame_counter, 123);
  EXPECT_TRUE(oa2.odometry_ok);
  EXPECT_EQ(oa2.counter, 11);
}

TEST(DiagnosticMessages, OutOfRangeValuesSaturateAndSetTheClampedFlag) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();

  // 10 km east does not fit 24 bits at 1 mm: the limit, not a wrapped (negative) value.
  PackStats s1;
  RegistrationPosition rp{10000.0, -inf, true, false, false, 0}, rp2;
  ASSERT_EQ(unpack(pack(rp, &s1), rp2), DecodeStatus::kOk);
  EXPECT_EQ(s1.saturated, 2u);
  EXPECT_NEAR(rp2.x_m, 8388.607, 1e-9);
  EXPECT_NEAR(rp2.y_m, -8388.608, 1e-9);
  EXPECT_TRUE(rp2.clamped);

  // 0x211 has no flag bit of its own: PackStats counts, the encoder flags it in 0x210.
  PackStats s2;
  RegistrationQuality rq{40.0, 1.5, nan, 7, 0}, rq2;
  ASSERT_EQ(unpack(pack(rq, &s2), rq2), DecodeStatus::kOk);
  EXPECT_EQ(s2.saturated, 3u);
  EXPECT_NEAR(rq2.z_m, 32.767, 1e-9);
  EXPECT_NEAR(rq2.fitness, 1.023, 1e-9);
  EXPECT_EQ(rq2.inlier_rmse_m, 0.0);  // NaN -> the in-range value nearest zero

  PackStats s3;
  OdometryPosition op{-9000.0, 1.0, true, false, 0}, op2;
  ASSERT_EQ(unpack(pack(op, &s3), op2), DecodeStatus::kOk);
  EXPECT_EQ(s3.saturated, 1u);
  EXPECT_NEAR(op2.x_m, -8388.608, 1e-9);
  EXPECT_NEAR(op2.y_m, 1.0, 5e-4);
  EXPECT_TRUE(op2.clamped);

  PackStats s4;
  OdometryAttitude oa{-100.0, 7.0 * 3.14159265358979, 1, true, false, 0}, oa2;
  ASSERT_EQ(unpack(pack(oa, &s4), oa2), DecodeStatus::kOk);
  EXPECT_EQ(s4.saturated, 1u);  // z only: yaw wraps
  EXPECT_NEAR(oa2.z_m, -32.768, 1e-9);
  EXPECT_NEAR(std::abs(oa2.yaw_rad), 3.1416, 1e-4);
  EXPECT_TRUE(oa2.clamped);

  // An in-range frame keeps the flag clear unless the caller sets it (companion frame clamped).
  RegistrationPosition in_range{1.0, 2.0, true, true, false, 0}, flagged_by_caller{1.0, 2.0, true, true, true, 0}, out;
  ASSERT_EQ(unpack(pack(in_range), out), DecodeStatus::kOk);
  EXPECT_FALSE(out.clamped);
  ASSERT_EQ(unpack(pack(flagged_by_caller), out), DecodeStatus::kOk);
  EXPECT_TRUE(out.clamped);

  // A mode the packer cannot express saturates to the top code (counted).
  PackStats s5;
  GateDecision gd;
  gd.mode = static_cast<LocalizerModeCode>(3);
  GateDecision gd2;
  ASSERT_EQ(unpack(pack(gd, &s5), gd2), DecodeStatus::kOk);
  EXPECT_EQ(s5.saturated, 1u);
  EXPECT_EQ(gd2.mode, LocalizerModeCode::kTracking);
}

TEST(DiagnosticMessages, RawValuesBeyondTheRangeAreReportedOutOfRange) {
  // Mode 3 does not exist; a faulty sender with a valid CRC is flagged, values still written.
  CanFrame f = pack(GateDecision{});
  put_bits_le(f.data, 34, 2, 3);
  f.data[7] = frame_crc(f.id, f.data);
  GateDecision gd;
  EXPECT_EQ(unpack(f, gd), DecodeStatus::kOutOfRange);
  // Fitness raw 1023 is the range end (in range); the 10-bit field cannot exceed it.
  CanFrame q = pack(RegistrationQuality{0.0, 1.023, 0.0, 0, 0});
  RegistrationQuality rq;
  EXPECT_EQ(unpack(q, rq), DecodeStatus::kOk);
  EXPECT_NEAR(rq.fitness, 1.023, 1e-9);
}

}  // namespace
}  // namespace v2xloc::protocol
