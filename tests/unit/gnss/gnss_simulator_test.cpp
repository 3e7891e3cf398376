#include "host_sim/gnss/gnss_simulator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "canyon_world.hpp"

namespace v2xloc::sim {
namespace {

struct DriveStats {
  double mean_h = 0.0, max_h = 0.0, mean_hdop = 0.0, min_hdop = 1e9, max_hdop = 0.0;
  double lag1_autocorr = 0.0, mean_sats = 0.0, mean_nlos = 0.0, mean_h_acc = 0.0;
  double mean_vel_err = 0.0, max_heading_err_deg = 0.0, mean_heading_err_deg = 0.0, mean_speed_acc = 0.0;
  int valid = 0, total = 0, velocity_valid = 0;
  int heading_outside_3sigma = 0;
  int heading_over_45deg = 0;  // heading error beyond 3x the reported heading sigma (+1 deg)
  std::vector<GnssFix> fixes;
  std::vector<Eigen::Vector3d> truth;
};

const GeodeticOrigin& munich() {
  static const GeodeticOrigin o = make_geodetic_origin(48.137154, 11.576124, 519.0);
  return o;
}

// 30 s north along the canyon's right lane at 10 m/s, fixes at 10 Hz.
DriveStats drive(const RayCaster& world, std::uint64_t seed, double rate_hz = 10.0, double epoch = 0.0) {
  GnssConfig cfg;
  cfg.epoch_offset_s = epoch;
  GnssSimulator sim(cfg, world, munich(), seed);
  DriveStats s;
  const int n = static_cast<int>(30.0 * rate_hz);
  std::vector<Eigen::Vector2d> err;
  for (int i = 0; i < n; ++i) {
    const double t = i / rate_hz;
    const Eigen::Vector3d truth(1.75, -150.0 + 10.0 * t, 1.8);
    const Eigen::Vector3d velocity(0.0, 10.0, 0.0);
    const GnssFix f = sim.fix(t, truth, velocity);
    s.fixes.push_back(f);
    s.truth.push_back(truth);
    ++s.total;
    if (!f.valid) continue;
    ++s.valid;
    // The fix is geodetic: map it back through the geodesy, not through the diagnostic field.
    const Eigen::Vector3d enu = geodetic_to_enu(munich(), {f.lat_deg, f.lon_deg, f.alt_m});
    const Eigen::Vector2d e = (enu - truth).head<2>();
    err.push_back(e);
    s.mean_h += e.norm();
    s.max_h = std::max(s.max_h, e.norm());
    s.mean_hdop += f.hdop;
    s.min_hdop = std::min(s.min_hdop, f.hdop);
    s.max_hdop = std::max(s.max_hdop, f.hdop);
    s.mean_sats += f.num_sats;
    s.mean_nlos += f.num_nlos;
    s.mean_h_acc += f.h_acc_m;
    if (f.velocity_valid) {
      ++s.velocity_valid;
      s.mean_vel_err += std::hypot(f.vel_east - velocity.x(), f.vel_north - velocity.y());
      const double heading_err = std::abs(std::atan2(f.vel_east, f.vel_north)) * 180.0 / 3.14159265358979;
      s.mean_heading_err_deg += heading_err;
      s.max_heading_err_deg = std::max(s.max_heading_err_deg, heading_err);
      s.mean_speed_acc += f.speed_acc_mps;
      const double heading_sigma_deg = std::atan2(f.speed_acc_mps, 10.0) * 180.0 / 3.14159265358979;
      if (heading_err > 3.0 * heading_sigma_deg + 1.0) ++s.heading_outside_3sigma;
      if (heading_err > 45.0) ++s.heading_over_45deg;
    }
  }
  if (s.velocity_valid > 0) {
    s.mean_vel_err /= s.velocity_valid;
    s.mean_heading_err_deg /= s.velocity_valid;
    s.mean_speed_acc /= s.velocity_valid;
  }
  if (s.valid > 0) {
    s.mean_h /= s.valid;
    s.mean_hdop /= s.valid;
    s.mean_sats /= s.valid;
    s.mean_nlos /= s.valid;
    s.mean_h_acc /= s.valid;
  }
  // Lag-1 autocorrelation of the east and north error components (averaged).
  double ac = 0.0;
  for (int c = 0; c < 2; ++c) {
    double mean = 0.0;
    for (const auto& e : err) mean += e(c);
    mean /= static_cast<double>(err.size());
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < err.size(); ++i) {
      den += (err[i](c) - mean) * (err[i](c) - mean);
      if (i > 0) num += (err[i](c) - mean) * (err[i - 1](c) - mean);
    }
    ac += 0.5 * num / den;
  }
  s.lag1_autocorr = ac;
  return s;
}

void print(const char* name, const DriveStats& s) {
  std::printf("%-8s valid %d/%d  mean h err %.2f m  max %.2f m  HDOP %.2f..%.2f (mean %.2f)  sats %.1f  nlos %.1f  "
              "h_acc %.2f  lag1 %.3f  vel err %.3f m/s (s_acc %.3f)  heading err mean %.2f max %.2f deg (> 3 sigma: %d, > 45 deg: %d)\n",
              name, s.valid, s.total, s.mean_h, s.max_h, s.min_hdop, s.max_hdop, s.mean_hdop, s.mean_sats,
              s.mean_nlos, s.mean_h_acc, s.lag1_autocorr, s.mean_vel_err, s.mean_speed_acc, s.mean_heading_err_deg,
              s.max_heading_err_deg, s.heading_outside_3sigma, s.heading_over_45deg);
}

TEST(GnssSimulator, CanyonErrorInPaperBandOpenSkySmall) {
  // Eight 30 s drives at different constellation epochs (the geometry differs per epoch, so the
  // per-drive error spreads like the paper's per-scenario GPS column does).
  const test::BoxWorld canyon = test::make_canyon();
  const test::OpenSky open;
  double canyon_sum = 0.0, lag1_sum = 0.0, h_acc_sum = 0.0;
  int n = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const double epoch = 3600.0 * static_cast<double>(seed);
    const DriveStats c = drive(canyon, seed, 10.0, epoch);
    const DriveStats o = drive(open, seed, 10.0, epoch);
    print("canyon", c);
    print("open", o);
    canyon_sum += c.mean_h;
    ++n;
    EXPECT_GE(c.valid, c.total * 9 / 10);
    EXPECT_EQ(o.valid, o.total);
    EXPECT_GE(c.mean_h, 3.0) << "seed " << seed;
    EXPECT_LE(c.mean_h, 25.0) << "seed " << seed;
    EXPECT_LE(o.mean_h, 3.0) << "seed " << seed;
    EXPECT_GT(c.mean_h, 2.0 * o.mean_h);
    EXPECT_GT(c.mean_hdop, o.mean_hdop * 1.3) << "buildings must worsen the geometry";
    EXPECT_GT(c.max_hdop, 2.0 * o.max_hdop);
    EXPECT_GT(c.lag1_autocorr, 0.6) << "canyon errors are time-correlated (jumps when satellites change)";
    lag1_sum += c.lag1_autocorr;
    h_acc_sum += c.mean_h_acc;
    EXPECT_GT(o.lag1_autocorr, 0.9) << "open-sky errors are time-correlated";
    // Doppler velocity: reflections hardly bias it along a street (the facades are parallel to the
    // motion), so the course over ground stays a usable heading where the position does not.
    EXPECT_EQ(c.velocity_valid, c.valid);
    EXPECT_LT(o.mean_vel_err, 0.1) << "seed " << seed;
    EXPECT_LT(o.max_heading_err_deg, 2.0) << "seed " << seed;
    EXPECT_LT(c.mean_heading_err_deg, 5.0) << "seed " << seed;
    EXPECT_LE(c.heading_over_45deg, c.velocity_valid / 50) << "seed " << seed;
    EXPECT_GT(c.mean_vel_err, o.mean_vel_err) << "NLOS range rates must cost something";
  }
  const double canyon_mean = canyon_sum / n;
  std::printf("canyon mean over %d drives: %.2f m\n", n, canyon_mean);
  EXPECT_GE(canyon_mean, 8.0);
  EXPECT_LE(canyon_mean, 17.0);
  EXPECT_GT(lag1_sum / n, 0.8);
  // The receiver's reported accuracy understates canyon errors (it cannot see NLOS delays).
  EXPECT_LT(h_acc_sum / n, 0.6 * canyon_mean);
}

TEST(GnssSimulator, DeterministicPerSeedAndSeedsDiffer) {
  const test::BoxWorld canyon = test::make_canyon();
  const DriveStats a = drive(canyon, 42, 5.0), b = drive(canyon, 42, 5.0), c = drive(canyon, 43, 5.0);
  ASSERT_EQ(a.fixes.size(), b.fixes.size());
  bool any_difference = false;
  for (std::size_t i = 0; i < a.fixes.size(); ++i) {
    EXPECT_EQ(a.fixes[i].lat_deg, b.fixes[i].lat_deg);
    EXPECT_EQ(a.fixes[i].lon_deg, b.fixes[i].lon_deg);
    EXPECT_EQ(a.fixes[i].alt_m, b.fixes[i].alt_m);
    EXPECT_EQ(a.fixes[i].hdop, b.fixes[i].hdop);
    any_difference |= a.fixes[i].lat_deg != c.fixes[i].lat_deg;
  }
  EXPECT_TRUE(any_difference);
}

TEST(GnssSimulator, FixFieldsAreConsistent) {
  const test::OpenSky open;
  GnssSimulator sim(GnssConfig{}, open, munich(), 5);
  const GnssFix f = sim.fix(0.0, Eigen::Vector3d(10.0, 20.0, 1.8), Eigen::Vector3d(3.0, -4.0, 0.0));
  ASSERT_TRUE(f.valid);
  EXPECT_GE(f.num_sats, 10);
  EXPECT_LE(f.num_sats, 20);
  EXPECT_EQ(f.num_sats, f.num_visible);
  EXPECT_GT(f.pdop, f.hdop);
  EXPECT_NEAR(f.h_acc_m, GnssConfig{}.sigma_uere_m * f.hdop, 1e-9);
  const Eigen::Vector3d enu = geodetic_to_enu(munich(), {f.lat_deg, f.lon_deg, f.alt_m});
  EXPECT_LT((enu - f.enu_estimate).norm(), 1e-3);
  EXPECT_LT((enu - Eigen::Vector3d(10.0, 20.0, 1.8)).norm(), 8.0);
}

}  // namespace
}  // namespace v2xloc::sim
