// Frames without LiDAR data are no evidence against the track (PoseFilter, FrameRegistration::
// no_data): they do not count towards filter.max_failed_frames, the filter predicts and its
// covariance grows, and tracking ends only when the prediction's sigma passes
// filter.tracking_max_sigma_xy. Failed registrations still start the search as before.
#include <gtest/gtest.h>

#include <memory>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"

namespace v2xloc {
namespace {

constexpr double kSpeed = 6.0;  // [m/s]

std::unique_ptr<PoseFilter> started_filter(const PoseFilterParams& params) {
  auto filter = std::make_unique<PoseFilter>();
  filter->configure(params, true);
  filter->start(10.0, Pose3d::Identity(), VehicleMotion{true, kSpeed, 0.0});
  return filter;
}

// Frame k at 10 s + k periods: the vehicle signals, the prediction, then a registration that found
// nothing: no data (an empty sweep) or a failed one.
void frame_without_registration(PoseFilter& filter, std::uint32_t k, bool no_data, LocalizerCounters& counters) {
  const double t = 10.0 + 0.1 * k;
  filter.on_vehicle(t, kSpeed, 0.0);
  filter.predict_to(t);
  FrameRegistration reg;
  reg.frame = k;
  reg.t = t;
  reg.result.status = RegistrationStatus::kNotEnoughPoints;
  reg.attempted_ok = true;
  reg.no_data = no_data;
  filter.fuse(reg, counters);
}

TEST(NoDataFrames, DoNotStartTheSearchWhileThePredictionIsTight) {
  const PoseFilterParams params;
  auto blind = started_filter(params);
  auto failing = started_filter(params);
  LocalizerCounters blind_counters, failing_counters;
  const std::uint32_t frames = 3 * params.max_failed_frames;  // 3 s
  for (std::uint32_t k = 1; k <= frames; ++k) {
    frame_without_registration(*blind, k, true, blind_counters);
    frame_without_registration(*failing, k, false, failing_counters);
  }
  EXPECT_FALSE(blind->needs_start());
  EXPECT_TRUE(blind->can_track());
  EXPECT_LT(blind->sigma_xy(), params.tracking_max_sigma_xy);
  EXPECT_EQ(blind_counters.registrations_gate_rejected, 0u) << "no registration to reject";
  // The same frames as failed registrations: the search starts after max_failed_frames.
  EXPECT_TRUE(failing->needs_start());
  EXPECT_FALSE(failing->can_track());
  EXPECT_EQ(failing_counters.registrations_gate_rejected, frames);
  EXPECT_DOUBLE_EQ(blind->sigma_xy(), failing->sigma_xy()) << "the same prediction either way";
}

TEST(NoDataFrames, TrackingEndsWhenThePredictionOutgrowsTheTrackingSigma) {
  const PoseFilterParams params;
  auto filter = started_filter(params);
  LocalizerCounters counters;
  double sigma_before = filter->sigma_xy();
  std::uint32_t k = 1;
  for (; k <= 100000 && filter->can_track(); ++k) {
    frame_without_registration(*filter, k, true, counters);
    EXPECT_GE(filter->sigma_xy(), sigma_before) << "frame " << k;
    sigma_before = filter->sigma_xy();
  }
  ASSERT_FALSE(filter->can_track()) << "the prediction's sigma never passed the tracking threshold";
  EXPECT_GT(filter->sigma_xy(), params.tracking_max_sigma_xy);
  EXPECT_GT(k, 3 * params.max_failed_frames) << "tracked through the first seconds without data";
  EXPECT_FALSE(filter->needs_start()) << "the sigma rule, not a failure count, ends tracking";
}

}  // namespace
}  // namespace v2xloc
