#include "host_sim/gnss/gnss_models.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace v2xloc::sim::gnss {
namespace {

TEST(GnssModels, IonosphereFormula) {
  // 10 TECU at L1: 40.3 * 1e17 / 1575.42e6^2 = 1.6237 m (the textbook ~0.162 m per TECU).
  EXPECT_NEAR(iono_delay_m(10 * kTecUnit, 1575.42e6), 1.6237, 1e-3);
  EXPECT_NEAR(iono_slant_factor(3.14159265358979 / 2, 350e3), 1.0, 1e-12);
  EXPECT_GT(iono_slant_factor(10 * 3.14159265358979 / 180, 350e3), 2.5);
  EXPECT_LT(iono_slant_factor(10 * 3.14159265358979 / 180, 350e3), 3.2);
}

TEST(GnssModels, Troposphere) {
  const double z = saastamoinen_zenith_m(1013.25, 288.15, 0.5, 0.84, 0.0);
  EXPECT_GT(z, 2.3);
  EXPECT_LT(z, 2.5);
  EXPECT_NEAR(tropo_mapping(3.14159265358979 / 2), 1.0, 1e-3);
  EXPECT_GT(tropo_mapping(0.1745), 5.0);
}

TEST(GnssModels, MultipathEquationOne) {
  const ReflectedPath paths[2] = {{0.5, 10.0, 0.1}, {0.25, 4.0, 0.0}};
  EXPECT_NEAR(multipath_delay_m(paths, 2), 0.5 * 10.1 + 0.25 * 4.0, 1e-12);
  EXPECT_EQ(multipath_delay_m(paths, 0), 0.0);
}

TEST(GnssModels, GaussMarkovIsStationary) {
  double x = 0.0, sum2 = 0.0;
  std::uint64_t s = 99;
  for (int i = 0; i < 200000; ++i) {
    // Cheap deterministic normal: sum of 12 uniforms - 6.
    double w = -6.0;
    for (int k = 0; k < 12; ++k) {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      w += static_cast<double>(s >> 11) * 0x1.0p-53;
    }
    x = gauss_markov_step(x, 2.0, 5.0, 0.1, w);
    sum2 += x * x;
  }
  EXPECT_NEAR(std::sqrt(sum2 / 200000), 2.0, 0.15);
}

TEST(GnssModels, WlsRecoversPositionAndClockExactly) {
  const auto origin = make_geodetic_origin(48.1, 11.5, 500.0);
  const Eigen::Vector3d truth = enu_to_ecef(origin, Eigen::Vector3d(30.0, -40.0, 2.0));
  std::vector<PseudorangeObservation> obs;
  const double az[] = {0.1, 1.3, 2.2, 3.0, 4.1, 5.2, 0.7};
  const double el[] = {1.2, 0.5, 0.3, 0.9, 0.25, 0.6, 0.2};
  for (int i = 0; i < 7; ++i) {
    const Eigen::Vector3d dir_enu(std::cos(el[i]) * std::sin(az[i]), std::cos(el[i]) * std::cos(az[i]), std::sin(el[i]));
    PseudorangeObservation o;
    o.sat_ecef = truth + 2.2e7 * origin.enu_from_ecef.transpose() * dir_enu;
    o.pseudorange_m = (o.sat_ecef - truth).norm() + 1234.5;
    o.sigma_m = 1.0 + i;
    obs.push_back(o);
  }
  Eigen::Vector4d init;
  init << origin.ecef, 0.0;
  const WlsSolution sol = solve_position_wls(obs, init, 10, origin);
  ASSERT_TRUE(sol.converged);
  EXPECT_LT((sol.state.head<3>() - truth).norm(), 1e-3);
  EXPECT_NEAR(sol.state(3), 1234.5, 1e-3);
  EXPECT_GT(sol.hdop, 0.5);
  EXPECT_GT(sol.pdop, sol.hdop);
  obs.resize(3);
  EXPECT_FALSE(solve_position_wls(obs, init, 10, origin).converged);
}

// Range rates from a known receiver velocity and drift over a spread geometry.
std::vector<RangeRateObservation> range_rates(const v2xloc::GeodeticOrigin& origin, const Eigen::Vector3d& vel_enu,
                                              double drift) {
  const Eigen::Vector3d vel_ecef = origin.enu_from_ecef.transpose() * vel_enu;
  std::vector<RangeRateObservation> obs;
  const double az_deg[] = {10, 70, 130, 190, 250, 310, 40, 220};
  const double el_deg[] = {15, 35, 60, 25, 45, 80, 20, 30};
  for (int i = 0; i < 8; ++i) {
    const double az = az_deg[i] * M_PI / 180.0, el = el_deg[i] * M_PI / 180.0;
    const Eigen::Vector3d los_enu(std::cos(el) * std::sin(az), std::cos(el) * std::cos(az), std::sin(el));
    RangeRateObservation o;
    o.los_ecef = origin.enu_from_ecef.transpose() * los_enu;
    o.sat_vel_ecef = Eigen::Vector3d(1000.0 * i, -2500.0, 3000.0 - 500.0 * i);
    o.range_rate_mps = o.los_ecef.dot(o.sat_vel_ecef - vel_ecef) + drift;
    o.sigma_mps = 0.1;
    obs.push_back(o);
  }
  return obs;
}

TEST(GnssModels, VelocityWlsRecoversVelocityAndExcludesAFault) {
  const auto origin = v2xloc::make_geodetic_origin(48.1, 11.5, 500.0);
  const Eigen::Vector3d truth(3.0, -7.5, 0.2);
  std::vector<RangeRateObservation> obs = range_rates(origin, truth, 1.5);
  const VelocitySolution exact = solve_velocity_wls(obs, origin);
  ASSERT_TRUE(exact.valid);
  EXPECT_LT((exact.vel_enu - truth).norm(), 1e-9);
  EXPECT_NEAR(exact.clock_drift_mps, 1.5, 1e-9);
  EXPECT_EQ(exact.excluded, 0);
  EXPECT_GT(exact.hdop, 0.0);
  // One reflected signal 6 m/s off (driving towards a facade): excluded, solution restored.
  obs[3].range_rate_mps += 6.0;
  const VelocitySolution faulty = solve_velocity_wls(obs, origin);
  ASSERT_TRUE(faulty.valid);
  EXPECT_EQ(faulty.excluded, 1);
  EXPECT_EQ(faulty.used, 7);
  EXPECT_LT((faulty.vel_enu - truth).norm(), 1e-9);
  // Without exclusion the fault spreads into the solution and the residuals say so.
  const VelocitySolution kept = solve_velocity_wls(obs, origin, 4.0, 0);
  EXPECT_GT((kept.vel_enu - truth).norm(), 0.5);
  EXPECT_GT(kept.unit_weight_sigma, 5.0);
  // Too few observations: no solution.
  obs.resize(3);
  EXPECT_FALSE(solve_velocity_wls(obs, origin).valid);
}

}  // namespace
}  // namespace v2xloc::sim::gnss
