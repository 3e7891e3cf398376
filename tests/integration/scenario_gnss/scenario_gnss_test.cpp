// The GNSS each recording carries, computed exactly as the recorder does (simulate_gnss_drive with
// the recorder's defaults), for Sim 0-3 in the intersection world with and without its buildings.
#include <gtest/gtest.h>

#include <cstdio>

#include "host_sim/recording/gnss_drive.hpp"
#include "host_sim/recording/recorder.hpp"
#include "host_sim/scenario/simulation.hpp"

namespace v2xloc::sim {
namespace {

GnssDrive drive_for(int scenario_id, bool buildings) {
  const RecorderConfig rc;  // the recorder's seed, origin, GNSS rate
  WorldConfig wc;
  wc.buildings = buildings;
  Simulation sim;
  build_simulation(scenario_id, rc.seed, 0.0, wc, sim);
  const auto origin = v2xloc::make_geodetic_origin(rc.origin_lat_deg, rc.origin_lon_deg, rc.origin_alt_m);
  return simulate_gnss_drive(sim.scenario, sim.iw.world, origin, rc.seed, rc.gnss_rate_hz,
                             Eigen::Vector3d(0.0, 0.0, 1.75));
}

TEST(ScenarioGnss, EachSimInPaperBandAndOpenSkyFewMetres) {
  double hdop_canyon_max = 0.0, hdop_open_max = 0.0;
  for (int id = 0; id < kScenarioCount; ++id) {
    const GnssDrive canyon = drive_for(id, true);
    const GnssDrive open = drive_for(id, false);
    std::printf("sim%d canyon: valid %d/%zu mean %.2f m max %.2f m HDOP %.1f-%.1f | open sky: mean %.2f m max %.2f m "
                "HDOP %.1f-%.1f\n",
                id, canyon.valid, canyon.fixes.size(), canyon.mean_h_error, canyon.max_h_error, canyon.hdop_min,
                canyon.hdop_max, open.mean_h_error, open.max_h_error, open.hdop_min, open.hdop_max);
    EXPECT_GE(canyon.valid, static_cast<int>(canyon.fixes.size()) * 9 / 10) << "sim" << id;
    EXPECT_GE(canyon.mean_h_error, 8.0) << "sim" << id;
    EXPECT_LE(canyon.mean_h_error, 17.0) << "sim" << id;
    EXPECT_LE(open.mean_h_error, 3.0) << "sim" << id;
    EXPECT_EQ(open.valid, static_cast<int>(open.fixes.size())) << "sim" << id;
    hdop_canyon_max = std::max(hdop_canyon_max, canyon.hdop_max);
    hdop_open_max = std::max(hdop_open_max, open.hdop_max);
  }
  EXPECT_GT(hdop_canyon_max, 1.5 * hdop_open_max) << "buildings blocking the sky must raise HDOP";
}

TEST(ScenarioGnss, DrivesHaveTheirOwnDraws) {
  // Sim 0 and Sim 2 start on the same eastbound lane: their GNSS must still differ (own seed, own time).
  const GnssDrive a = drive_for(0, true);
  const GnssDrive b = drive_for(2, true);
  ASSERT_GT(a.valid, 0);
  ASSERT_GT(b.valid, 0);
  EXPECT_NE(a.mean_h_error, b.mean_h_error);
  EXPECT_NE(a.fixes[10].enu_estimate.x(), b.fixes[10].enu_estimate.x());
}

}  // namespace
}  // namespace v2xloc::sim
