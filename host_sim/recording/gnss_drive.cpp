#include "host_sim/recording/gnss_drive.hpp"

#include <algorithm>
#include <cmath>

#include "host_sim/common/rng.hpp"

namespace v2xloc::sim {

std::uint64_t gnss_stream_seed(std::uint64_t recording_seed, int scenario_id) {
  constexpr std::uint64_t kGnssStream = 6;  // the recorder's stream id for GNSS noise
  return derive_seed(recording_seed, {kGnssStream, static_cast<std::uint64_t>(scenario_id)});
}

GnssDrive simulate_gnss_drive(const Scenario& scenario, World& world, const v2xloc::GeodeticOrigin& origin,
                              std::uint64_t recording_seed, double rate_hz, const Eigen::Vector3d& antenna_in_body,
                              GnssConfig config) {
  GnssDrive out;
  config.epoch_offset_s = scenario.gnss_epoch_offset_s;
  world.set_time(0.0);
  GnssSimulator gnss(config, world, origin, gnss_stream_seed(recording_seed, scenario.id));
  const int n = static_cast<int>(std::floor(scenario.duration * rate_hz + 1e-9));
  double sum = 0.0, hmin = 1e9;
  for (int k = 0; k < n; ++k) {
    const double t = k / rate_hz;
    world.set_time(t);
    const Eigen::Vector3d antenna = scenario.ego.body_to_enu(t) * antenna_in_body;
    // Antenna velocity by a central difference of the trajectory (includes the lever arm's part).
    constexpr double kHalfStep = 0.005;  // s
    const Eigen::Vector3d velocity = (scenario.ego.body_to_enu(t + kHalfStep) * antenna_in_body -
                                      scenario.ego.body_to_enu(t - kHalfStep) * antenna_in_body) /
                                     (2.0 * kHalfStep);
    const GnssFix fix = gnss.fix(t, antenna, velocity);
    out.true_velocity.push_back(velocity);
    out.fixes.push_back(fix);
    out.true_antenna.push_back(antenna);
    if (!fix.valid) continue;
    const double e = (fix.enu_estimate.head<2>() - antenna.head<2>()).norm();
    sum += e;
    out.max_h_error = std::max(out.max_h_error, e);
    hmin = std::min(hmin, fix.hdop);
    out.hdop_max = std::max(out.hdop_max, fix.hdop);
    ++out.valid;
    if (fix.velocity_valid) {
      const Eigen::Vector2d v(fix.vel_east, fix.vel_north);
      const double ve = (v - velocity.head<2>()).norm();
      out.mean_velocity_error += ve;
      out.max_velocity_error = std::max(out.max_velocity_error, ve);
      ++out.velocity_valid;
    }
  }
  if (out.velocity_valid > 0) out.mean_velocity_error /= out.velocity_valid;
  world.set_time(0.0);
  if (out.valid > 0) {
    out.mean_h_error = sum / out.valid;
    out.hdop_min = hmin;
  }
  return out;
}

}  // namespace v2xloc::sim
