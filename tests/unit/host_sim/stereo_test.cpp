#include "host_sim/sensors/stereo.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace v2xloc::sim {
namespace {

TEST(HostSimStereo, DisparityOfAFrontoParallelWallIsFxBaselineOverDepth) {
  World w;
  w.set_ground_plane(false);
  w.add(Primitive::box({20.8, -200, -200}, {21.8, 200, 200}, kMatBuilding, w.new_object_id()));
  w.build();
  StereoConfig c;
  c.downsample = 4;
  c.random_invalid = 0.0;
  const StereoCalibration cal = c.calibration();
  EXPECT_EQ(cal.width, 1242 / 4);
  EXPECT_NEAR(cal.fx, 721.5 / 4, 1e-12);
  Rng rng(4);
  Image16 img;
  const DisparityStats st = render_disparity(w, c, Eigen::Isometry3d::Identity(), 0.0, -1, rng, img);
  ASSERT_EQ(st.valid, static_cast<std::size_t>(cal.width * cal.height));
  const double depth = 20.8 - c.left_camera_position.x();  // camera looks along body +x
  const double expected = cal.fx * cal.baseline / depth;
  double s = 0, s2 = 0;
  for (std::uint16_t v : img.pixels) {
    const double d = v / 256.0 - expected;
    s += d;
    s2 += d * d;
  }
  const double n = static_cast<double>(img.pixels.size());
  EXPECT_NEAR(s / n, 0.0, 0.01);
  EXPECT_NEAR(std::sqrt(s2 / n), c.disparity_sigma, 0.02);
}

TEST(HostSimStereo, SkyAndOcclusionAreInvalid) {
  World w;  // ground plane only, plus a pole right in front of the left camera
  w.add(Primitive::cylinder(3.0, 0.27, 0.0, 5.0, 0.1, kMatPole, w.new_object_id()));
  w.build();
  StereoConfig c;
  c.downsample = 4;
  c.random_invalid = 0.0;
  Rng rng(5);
  Image16 img;
  const DisparityStats st = render_disparity(w, c, Eigen::Isometry3d::Identity(), 0.0, -1, rng, img);
  EXPECT_GT(st.sky, 0u);       // upper rows see the sky
  EXPECT_GT(st.occluded, 0u);  // the right camera sees the pole's shadow region differently
  EXPECT_EQ(st.valid + st.sky + st.occluded + st.too_far + st.random_invalid, img.pixels.size());
  std::size_t zeros = 0;
  for (auto v : img.pixels) zeros += v == 0;
  EXPECT_EQ(zeros, img.pixels.size() - st.valid);
}

}  // namespace
}  // namespace v2xloc::sim
