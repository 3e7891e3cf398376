// Diagnostic frames: registration, gate decision and odometry of a localizer output survive the
// DBC codec within its resolution, carry the frame counter and one rolling counter, and a value
// that does not fit raises the clamped flag of its message pair (never a wrapped number).
#include <gtest/gtest.h>

#include <cmath>

#include "firmware/wire/diagnostic_frames.hpp"

namespace v2xloc::firmware {
namespace {

Mat4d pose(double x, double y, double z, double yaw) {
  Mat4d T = Mat4d::Identity();
  T(0, 0) = std::cos(yaw);
  T(0, 1) = -std::sin(yaw);
  T(1, 0) = std::sin(yaw);
  T(1, 1) = std::cos(yaw);
  T(0, 3) = x;
  T(1, 3) = y;
  T(2, 3) = z;
  return T;
}

LocalizerFrameOutput make_output() {
  LocalizerFrameOutput out;
  out.mode = LocalizationMode::kTracking;
  out.filter_initialized = true;
  out.registration_attempted = true;
  out.registration_status = RegistrationStatus::kOk;
  out.registration_pose = pose(-52.3456, 12.0004, 0.0123, 0.3);
  out.fitness = 0.8123;
  out.inlier_rmse = 0.0456;
  out.gate_decided = true;
  out.gate_decided_frame = 69995;  // 5 frames before 70000
  out.gate_decided_valid = true;
  out.odometry_ok = true;
  out.odometry_pose = pose(140.0006, -3.2104, -1.8996, -2.9);
  return out;
}

TEST(DiagnosticFrames, RoundTripThroughTheDbcCodec) {
  DiagnosticFrameEncoder enc;
  const LocalizerFrameOutput out = make_output();
  const DiagnosticFrames f = enc.encode(out, 70000);
  protocol::RegistrationPosition rp;
  protocol::RegistrationQuality rq;
  protocol::GateDecision gd;
  protocol::OdometryPosition op;
  protocol::OdometryAttitude oa;
  ASSERT_EQ(protocol::unpack(f.registration_position, rp), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.registration_quality, rq), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.gate, gd), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.odometry_position, op), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.odometry_attitude, oa), protocol::DecodeStatus::kOk);
  EXPECT_NEAR(rp.x_m, -52.3456, 5e-4);
  EXPECT_NEAR(rp.y_m, 12.0004, 5e-4);
  EXPECT_NEAR(rq.z_m, 0.0123, 5e-4);
  EXPECT_TRUE(rp.attempted && rp.ok);
  EXPECT_FALSE(rp.clamped);
  EXPECT_NEAR(rq.fitness, 0.8123, 5e-4);
  EXPECT_NEAR(rq.inlier_rmse_m, 0.0456, 5e-4);
  const auto counter = static_cast<std::uint16_t>(70000 & 0xFFFF);
  EXPECT_EQ(rq.frame_counter, counter);
  EXPECT_EQ(gd.frame_counter, counter);
  EXPECT_EQ(oa.frame_counter, counter);
  EXPECT_TRUE(gd.decided && gd.valid);
  EXPECT_EQ(gd.decided_frame, static_cast<std::uint16_t>(69995 & 0xFFFF));
  EXPECT_EQ(gd.mode, protocol::LocalizerModeCode::kTracking);
  EXPECT_TRUE(gd.filter_initialized);
  EXPECT_NEAR(op.x_m, 140.0006, 5e-4);
  EXPECT_NEAR(op.y_m, -3.2104, 5e-4);
  EXPECT_NEAR(oa.z_m, -1.8996, 5e-4);
  EXPECT_NEAR(oa.yaw_rad, -2.9, 5e-5);
  EXPECT_TRUE(op.odometry_ok && oa.odometry_ok);
  // One rolling counter for the five messages, +1 per frame.
  EXPECT_EQ(rp.counter, 0);
  EXPECT_EQ(oa.counter, 0);
  const DiagnosticFrames g = enc.encode(out, 70001);
  ASSERT_EQ(protocol::unpack(g.gate, gd), protocol::DecodeStatus::kOk);
  EXPECT_EQ(gd.counter, 1);
  EXPECT_EQ(enc.saturated_signals(), 0u);
}

TEST(DiagnosticFrames, FailedRegistrationAndNoDecisionAreFlaggedAsSuch) {
  DiagnosticFrameEncoder enc;
  LocalizerFrameOutput out = make_output();
  out.registration_status = RegistrationStatus::kDidNotConverge;
  out.gate_decided = false;
  out.gate_decided_valid = true;  // meaningless without a decision: not sent as valid
  const DiagnosticFrames f = enc.encode(out, 3);
  protocol::RegistrationPosition rp;
  protocol::GateDecision gd;
  ASSERT_EQ(protocol::unpack(f.registration_position, rp), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.gate, gd), protocol::DecodeStatus::kOk);
  EXPECT_TRUE(rp.attempted);
  EXPECT_FALSE(rp.ok);
  EXPECT_FALSE(gd.decided);
  EXPECT_FALSE(gd.valid);
}

TEST(DiagnosticFrames, ValuesOutsideTheirSignalsSaturateAndFlagBothFramesOfThePair) {
  DiagnosticFrameEncoder enc;
  LocalizerFrameOutput out = make_output();
  out.inlier_rmse = 2.0;                 // > 1.023 m, in 0x211 (which has no flag bit)
  out.odometry_pose(0, 3) = 12000.0;     // > 8388.607 m, in 0x213
  const DiagnosticFrames f = enc.encode(out, 1);
  protocol::RegistrationPosition rp;
  protocol::RegistrationQuality rq;
  protocol::OdometryPosition op;
  protocol::OdometryAttitude oa;
  ASSERT_EQ(protocol::unpack(f.registration_position, rp), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.registration_quality, rq), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.odometry_position, op), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.odometry_attitude, oa), protocol::DecodeStatus::kOk);
  EXPECT_NEAR(rq.inlier_rmse_m, 1.023, 1e-9);
  EXPECT_TRUE(rp.clamped);
  EXPECT_NEAR(op.x_m, 8388.607, 1e-9);
  EXPECT_TRUE(op.clamped);
  EXPECT_TRUE(oa.clamped);               // z fits, but its companion frame was clamped
  EXPECT_NEAR(oa.z_m, -1.8996, 5e-4);
  EXPECT_EQ(enc.saturated_signals(), 2u);
}

}  // namespace
}  // namespace v2xloc::firmware
