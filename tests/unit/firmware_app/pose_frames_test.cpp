// Pose frames: the localizer output survives the DBC codec within its resolution, the three frames
// share the frame counter and a rolling counter, flags follow the output.
#include <gtest/gtest.h>

#include <cmath>

#include "firmware/wire/pose_frames.hpp"

namespace v2xloc::firmware {
namespace {

LocalizerFrameOutput make_output(double x, double y, double z, double yaw) {
  LocalizerFrameOutput out;
  out.mode = LocalizationMode::kTracking;
  out.fused_pose = Mat4d::Identity();
  out.fused_pose(0, 0) = std::cos(yaw);
  out.fused_pose(0, 1) = -std::sin(yaw);
  out.fused_pose(1, 0) = std::sin(yaw);
  out.fused_pose(1, 1) = std::cos(yaw);
  out.fused_pose(0, 3) = x;
  out.fused_pose(1, 3) = y;
  out.fused_pose(2, 3) = z;
  out.sigma_x = 0.031;
  out.sigma_y = 0.042;
  out.sigma_z = 0.1;
  out.sigma_yaw = 0.0123;
  out.localized = true;
  out.registration_fused = true;
  return out;
}

TEST(PoseFrames, RoundTripThroughTheDbcCodec) {
  PoseFrameEncoder enc;
  const LocalizerFrameOutput out = make_output(-123.4567, 45.6789, 1.23, 2.5);
  const PoseFrames f = enc.encode(out, 70000, true);
  EXPECT_EQ(f.position.id, protocol::kPosePositionId);
  EXPECT_EQ(f.attitude.id, protocol::kPoseAttitudeId);
  EXPECT_EQ(f.sigma.id, protocol::kPoseSigmaId);
  protocol::PosePosition p;
  protocol::PoseAttitude a;
  protocol::PoseSigma s;
  ASSERT_EQ(protocol::unpack(f.position, p), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.attitude, a), protocol::DecodeStatus::kOk);
  ASSERT_EQ(protocol::unpack(f.sigma, s), protocol::DecodeStatus::kOk);
  EXPECT_NEAR(p.x_m, -123.4567, 0.0005);
  EXPECT_NEAR(p.y_m, 45.6789, 0.0005);
  EXPECT_NEAR(a.z_m, 1.23, 0.005);
  EXPECT_NEAR(a.yaw_rad, 2.5, 0.00005);
  EXPECT_EQ(a.frame_counter, 70000 & 0xFFFF);
  EXPECT_NEAR(s.sigma_x_m, 0.031, 0.0025);
  EXPECT_NEAR(s.sigma_yaw_rad, 0.0123, 0.00005);
  EXPECT_TRUE(p.flags.pose_valid);
  EXPECT_TRUE(p.flags.registration_valid);
  EXPECT_TRUE(p.flags.gnss_used);
  EXPECT_FALSE(p.flags.degraded);
  EXPECT_EQ(p.counter, 0);
  EXPECT_EQ(a.counter, 0);
  EXPECT_EQ(s.counter, 0);
  const PoseFrames g = enc.encode(out, 70001, false);
  ASSERT_EQ(protocol::unpack(g.position, p), protocol::DecodeStatus::kOk);
  EXPECT_EQ(p.counter, 1);
  EXPECT_FALSE(p.flags.gnss_used);
}

TEST(PoseFrames, UnlocalizedOutputIsDegradedAndHeartbeatStateFollows) {
  LocalizerFrameOutput out = make_output(1, 2, 0, 0);
  out.localized = false;
  const protocol::PoseFlags f = pose_flags(out, false);
  EXPECT_FALSE(f.pose_valid);
  EXPECT_TRUE(f.degraded);
  EXPECT_EQ(localizer_state(nullptr), protocol::LocalizerState::kInit);
  EXPECT_EQ(localizer_state(&out), protocol::LocalizerState::kDegraded);
  out.localized = true;
  EXPECT_EQ(localizer_state(&out), protocol::LocalizerState::kLocalized);
  out.mode = LocalizationMode::kUninitialized;
  EXPECT_EQ(localizer_state(&out), protocol::LocalizerState::kWaitingForGnss);
}

// A period without LiDAR points (the period timer's, or a covered sensor's) is the filter's
// prediction: never reported as a registration, always flagged Degraded, still vouched for while
// its sigma is below the localized threshold.
TEST(PoseFrames, APeriodWithoutScanDataIsNoRegistrationAndDegraded) {
  LocalizerFrameOutput out = make_output(1.0, 2.0, 0.0, 0.0);
  out.filter_initialized = true;
  out.registration_fused = true;  // a fixed-lag decision about an earlier frame may land here
  out.no_scan_data = true;
  const protocol::PoseFlags f = pose_flags(out, false);
  EXPECT_TRUE(f.pose_valid);
  EXPECT_FALSE(f.registration_valid);
  EXPECT_TRUE(f.degraded);
  out.no_scan_data = false;
  const protocol::PoseFlags g = pose_flags(out, false);
  EXPECT_TRUE(g.registration_valid);
  EXPECT_FALSE(g.degraded);
}

}  // namespace
}  // namespace v2xloc::firmware
