#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "v2xloc/algo/localization/deskew.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/stereo_cloud.hpp"

namespace v2xloc {
namespace {

// A sensor moving at constant twist sweeps static wall points; each is recorded in the sensor
// frame at its own time. Deskewing with the true per-frame motion must put them back in the
// frame at the reference time.
TEST(Deskew, SyntheticMovingSweepIsCompensated) {
  Vec6d twist;  // per second: 10 m/s forward, 0.3 rad/s yaw
  twist << 10.0, 0.5, 0.0, 0.0, 0.0, 0.3;
  const double period = 0.1;
  const Mat4d delta = se3_exp(twist * period);
  std::vector<Vec3f> world, measured;
  std::vector<float> times;
  for (int i = 0; i < 1000; ++i) {
    const double t = period * i / 1000.0;
    const double az = 2.0 * det::kPi * i / 1000.0;
    const Vec3d pw(20.0 * det::cos(az), 20.0 * det::sin(az), -1.0 + 0.002 * i);
    // Sensor pose at t relative to the reference (scan start, t_ref = 0).
    const Mat4d T = se3_exp(twist * t);
    const Vec3d ps = T.topLeftCorner<3, 3>().transpose() * (pw - Vec3d(T.topRightCorner<3, 1>()));
    world.push_back(pw.cast<float>());
    measured.push_back(ps.cast<float>());
    times.push_back(static_cast<float>(t));
  }
  measured[5] = Vec3f(NAN, 0.0f, 0.0f);
  std::vector<Vec3f> out(measured.size());
  DeskewParams p;
  p.reference_time = 0.0;
  p.delta_duration = period;
  const DeskewResult r = deskew(measured, times, delta, p, out);
  ASSERT_EQ(r.status, DeskewStatus::kOk);
  EXPECT_EQ(r.non_finite_dropped, 1u);
  ASSERT_EQ(r.points_out, 999u);
  double max_err = 0.0, max_raw = 0.0;
  for (std::size_t i = 0, j = 0; i < world.size(); ++i) {
    if (i == 5) continue;
    max_err = std::max(max_err, double((out[j] - world[i]).norm()));
    max_raw = std::max(max_raw, double((measured[i] - world[i]).norm()));
    ++j;
  }
  std::printf("deskew: max error %.2e m (uncompensated %.3f m)\n", max_err, max_raw);
  EXPECT_LT(max_err, 1e-4);  // float storage of 20 m coordinates
  EXPECT_GT(max_raw, 0.5);
  // Truncation is counted.
  std::vector<Vec3f> small(10);
  const DeskewResult t = deskew(measured, times, delta, p, small);
  EXPECT_EQ(t.status, DeskewStatus::kTruncated);
  EXPECT_EQ(t.capacity_dropped, 989u);
}

// A sensor that stamps each laser's firing (~12 us apart, out of order within a block, as a real
// sweep's are): points near an anchor stamp take the motion's series, not their own exp. Returns
// the largest distance from the exact per-point exp over a sweep at 80 m ranges.
double per_laser_deskew_error(const Vec6d& twist, const int (&order)[4], double& max_motion) {
  const double period = 0.1;
  const Mat4d delta = se3_exp(twist * period);
  std::vector<Vec3f> measured;
  std::vector<float> times;
  for (int i = 0; i < 8000; ++i) {
    const double az = 2.0 * det::kPi * i / 8000.0;
    measured.push_back(Vec3f(static_cast<float>(80.0 * det::cos(az)), static_cast<float>(80.0 * det::sin(az)),
                             static_cast<float>(-2.0 + 0.001 * i)));
    times.push_back(static_cast<float>(12.4e-6 * (4 * (i / 4) + order[i % 4])));
  }
  std::vector<Vec3f> out(measured.size());
  DeskewParams p;
  p.reference_time = 0.05;
  p.delta_duration = period;
  const DeskewResult r = deskew(measured, times, delta, p, out);
  EXPECT_EQ(r.status, DeskewStatus::kOk);
  EXPECT_EQ(r.points_out, measured.size());
  const Vec6d xi = se3_log(delta) / period;
  double max_diff = 0.0;
  max_motion = 0.0;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const Mat4d T = se3_exp(xi * (static_cast<double>(times[i]) - p.reference_time));
    const Vec3d exact = T.topLeftCorner<3, 3>() * measured[i].cast<double>() + T.topRightCorner<3, 1>();
    max_diff = std::max(max_diff, (out[i].cast<double>() - exact).norm());
    max_motion = std::max(max_motion, (exact - measured[i].cast<double>()).norm());
  }
  return max_diff;
}

// A fast turning vehicle, a slow one (the series' span widest), and (a check of the series'
// second-order term and its sign) a sensor spinning at 30 rad/s (3 rad a period: within se3_log's range) with each block's last firing as
// its anchor: both match the exact exp to float resolution (7.6e-6 m a unit in the last place at
// 80 m; without the second-order term the spinning case is 5e-5 m off).
TEST(Deskew, PerLaserStampsMatchTheExactMotion) {
  Vec6d vehicle;  // per second: 20 m/s, 1 rad/s yaw, 0.2 rad/s roll
  vehicle << 20.0, 0.3, 0.1, 0.2, 0.0, 1.0;
  const int in_order[4] = {0, 2, 1, 3};
  double motion = 0.0;
  const double vehicle_err = per_laser_deskew_error(vehicle, in_order, motion);
  std::printf("deskew, per-laser stamps: max difference from the exact exp %.2e m (motion up to %.2f m)\n", vehicle_err,
              motion);
  EXPECT_LT(vehicle_err, 2e-5);
  EXPECT_GT(motion, 1.0);
  Vec6d spinning;
  spinning << 5.0, 0.0, 0.0, 0.0, 0.0, 30.0;
  const int before_anchor[4] = {3, 0, 1, 2};  // the anchor (first seen) is a block's last firing
  const double spinning_err = per_laser_deskew_error(spinning, before_anchor, motion);
  std::printf("deskew, 30 rad/s: max difference %.2e m\n", spinning_err);
  EXPECT_LT(spinning_err, 2e-5);
  // A slow turn widens the series' span (0.1 rad/s: 400 us, 32 firings an anchor): still exact.
  Vec6d slow;
  slow << 10.0, 0.0, 0.0, 0.0, 0.0, 0.1;
  const double slow_err = per_laser_deskew_error(slow, in_order, motion);
  std::printf("deskew, 0.1 rad/s: max difference %.2e m\n", slow_err);
  EXPECT_LT(slow_err, 2e-5);
}

// A fronto-parallel plane at 10 m: d = f b / z everywhere.
TEST(StereoCloud, PlaneDepthAndSigma) {
  StereoCalibration c;
  c.fx = c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.baseline = 0.5;
  // Camera looking forward along vehicle +x (z_cam -> x_veh, x_cam -> -y_veh, y_cam -> -z_veh),
  // mounted 1.5 m up.
  c.vehicle_T_camera << 0, 0, 1, 1.0, -1, 0, 0, 0.0, 0, -1, 0, 1.5, 0, 0, 0, 1;
  const std::uint32_t w = 640, h = 480;
  std::vector<float> disp(w * h, 25.0f);  // z = 500 * 0.5 / 25 = 10 m
  disp[0] = 0.0f;
  disp[2] = NAN;
  disp[4] = 0.5f;  // below min disparity
  StereoParams p;
  p.stride = 2;
  p.disparity_sigma = 0.5;
  std::vector<Vec3f> pts(w * h / 4);
  std::vector<float> sig(pts.size());
  const StereoCloudResult r = stereo_to_cloud(disp, w, h, c, p, pts, sig);
  ASSERT_EQ(r.status, StereoStatus::kOk);
  EXPECT_EQ(r.pixels_visited, w * h / 4);
  EXPECT_EQ(r.invalid, 2u);
  EXPECT_EQ(r.out_of_range, 1u);
  ASSERT_EQ(r.points_out, w * h / 4 - 3);
  for (std::uint32_t i = 0; i < r.points_out; ++i) {
    ASSERT_NEAR(pts[i].x(), 11.0f, 1e-4f);  // 10 m + 1 m mount offset
    ASSERT_NEAR(sig[i], 10.0 * 10.0 / (500.0 * 0.5) * 0.5, 1e-6);  // 0.2 m
  }
  // Pixel (u=320, v=240) looks straight ahead: y_veh = 0, z_veh = 1.5.
  const std::uint32_t idx = (240 / 2) * (w / 2) + 320 / 2 - 3;
  EXPECT_NEAR(pts[idx].y(), 0.0f, 1e-5f);
  EXPECT_NEAR(pts[idx].z(), 1.5f, 1e-5f);
  // uint16 with scale 1/16 (OpenCV SGBM): the same plane.
  std::vector<std::uint16_t> raw(w * h, 25 * 16);
  raw[7] = 0;
  const StereoCloudResult r16 = stereo_to_cloud(raw, 1.0 / 16.0, w, h, c, p, pts, sig);
  EXPECT_EQ(r16.invalid, 0u);  // pixel 7 is skipped by the stride
  EXPECT_EQ(r16.points_out, w * h / 4);
  EXPECT_NEAR(pts[0].x(), 11.0f, 1e-4f);
  // Capacity overflow counted.
  std::vector<Vec3f> few(100);
  const StereoCloudResult rt = stereo_to_cloud(disp, w, h, c, p, few, {});
  EXPECT_EQ(rt.status, StereoStatus::kTruncated);
  EXPECT_EQ(rt.capacity_dropped, w * h / 4 - 3 - 100);
}

}  // namespace
}  // namespace v2xloc
