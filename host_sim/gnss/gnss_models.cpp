#include "host_sim/gnss/gnss_models.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::sim::gnss {

double iono_delay_m(double tec_el_per_m2, double carrier_hz) {
  return 40.3 * tec_el_per_m2 / (carrier_hz * carrier_hz);
}

double iono_slant_factor(double elevation_rad, double shell_height_m) {
  const double s = wgs84::kSemiMajorAxis * det::cos(elevation_rad) / (wgs84::kSemiMajorAxis + shell_height_m);
  return 1.0 / std::sqrt(1.0 - s * s);
}

double saastamoinen_zenith_m(double pressure_hpa, double temperature_k, double relative_humidity,
                             double latitude_rad, double height_m) {
  // Water-vapour partial pressure from relative humidity (Magnus-type formula, hPa).
  const double e = 6.108 * relative_humidity * std::exp((17.15 * temperature_k - 4684.0) / (temperature_k - 38.45));
  const double hydrostatic = 0.0022768 * pressure_hpa /
                             (1.0 - 0.00266 * det::cos(2.0 * latitude_rad) - 0.00028 * height_m * 1e-3);
  const double wet = 0.002277 * (1255.0 / temperature_k + 0.05) * e;
  return hydrostatic + wet;
}

double tropo_mapping(double elevation_rad) {
  const double s = det::sin(elevation_rad);
  return 1.001 / std::sqrt(0.002001 + s * s);
}

double multipath_delay_m(const ReflectedPath* paths, std::size_t count) {
  double sum = 0.0;
  for (std::size_t k = 0; k < count; ++k) {
    sum += paths[k].attenuation * (paths[k].excess_m + paths[k].phase_m);
  }
  return sum;
}

double gauss_markov_step(double x, double sigma, double tau_s, double dt_s, double white_unit) {
  if (dt_s <= 0.0) return x;
  const double phi = std::exp(-dt_s / tau_s);
  return phi * x + sigma * std::sqrt(1.0 - phi * phi) * white_unit;
}

WlsSolution solve_position_wls(const std::vector<PseudorangeObservation>& obs,
                               const Eigen::Vector4d& initial, int max_iterations,
                               const v2xloc::GeodeticOrigin& frame) {
  WlsSolution sol;
  sol.state = initial;
  const std::size_t n = obs.size();
  if (n < 4) return sol;
  Eigen::MatrixXd g(n, 4);
  Eigen::VectorXd w(n), v(n);
  for (int it = 0; it < max_iterations; ++it) {
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d diff = obs[i].sat_ecef - sol.state.head<3>();
      const double range = diff.norm();
      g.row(static_cast<Eigen::Index>(i)) << -diff.transpose() / range, 1.0;
      v(static_cast<Eigen::Index>(i)) = obs[i].pseudorange_m - (range + sol.state(3));
      w(static_cast<Eigen::Index>(i)) = 1.0 / (obs[i].sigma_m * obs[i].sigma_m);
    }
    const Eigen::Matrix4d normal = g.transpose() * w.asDiagonal() * g;
    const Eigen::Vector4d rhs = g.transpose() * w.asDiagonal() * v;
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(normal);
    if (ldlt.info() != Eigen::Success) return sol;
    const Eigen::Vector4d dx = ldlt.solve(rhs);
    if (!dx.allFinite()) return sol;
    sol.state += dx;
    sol.iterations = it + 1;
    if (dx.head<3>().norm() < 1e-4) {
      sol.converged = true;
      break;
    }
  }
  // DOPs: unweighted geometry with line-of-sight vectors rotated into ENU.
  Eigen::MatrixXd h(n, 4);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d los = (obs[i].sat_ecef - sol.state.head<3>()).normalized();
    h.row(static_cast<Eigen::Index>(i)) << -(frame.enu_from_ecef * los).transpose(), 1.0;
  }
  const Eigen::Matrix4d htH = h.transpose() * h;
  const Eigen::LDLT<Eigen::Matrix4d> ldlt(htH);
  if (ldlt.info() != Eigen::Success) {
    sol.converged = false;
    return sol;
  }
  const Eigen::Matrix4d q = ldlt.solve(Eigen::Matrix4d::Identity());
  sol.hdop = std::sqrt(q(0, 0) + q(1, 1));
  sol.vdop = std::sqrt(q(2, 2));
  sol.pdop = std::sqrt(q(0, 0) + q(1, 1) + q(2, 2));
  if (!std::isfinite(sol.pdop) || q(0, 0) < 0.0 || q(1, 1) < 0.0 || q(2, 2) < 0.0) sol.converged = false;
  return sol;
}

VelocitySolution solve_velocity_wls(const std::vector<RangeRateObservation>& obs,
                                    const v2xloc::GeodeticOrigin& frame, double exclusion_sigmas,
                                    int max_exclusions, int min_used) {
  VelocitySolution sol;
  const std::size_t n = obs.size();
  std::vector<bool> active(n, true);
  // Model: rate_i = u_i . (v_sat_i - v_rx) + drift  ->  rate_i - u_i . v_sat_i = [-u_i 1] [v_rx; drift].
  for (int pass = 0; pass <= max_exclusions; ++pass) {
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Vector4d rhs = Eigen::Vector4d::Zero();
    int used = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      Eigen::Vector4d h;
      h << -obs[i].los_ecef, 1.0;
      const double w = 1.0 / (obs[i].sigma_mps * obs[i].sigma_mps);
      normal += w * h * h.transpose();
      rhs += w * h * (obs[i].range_rate_mps - obs[i].los_ecef.dot(obs[i].sat_vel_ecef));
      ++used;
    }
    if (used < 4) return sol;
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(normal);
    if (ldlt.info() != Eigen::Success) return sol;
    const Eigen::Vector4d x = ldlt.solve(rhs);
    if (!x.allFinite()) return sol;
    // Largest normalized residual of the active observations.
    double worst = 0.0, wssr = 0.0;
    std::size_t worst_i = n;
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      const double predicted = obs[i].los_ecef.dot(obs[i].sat_vel_ecef - x.head<3>()) + x(3);
      const double z = std::abs(obs[i].range_rate_mps - predicted) / obs[i].sigma_mps;
      wssr += z * z;
      if (z > worst) {
        worst = z;
        worst_i = i;
      }
    }
    sol.vel_enu = frame.enu_from_ecef * x.head<3>();
    sol.clock_drift_mps = x(3);
    sol.used = used;
    sol.unit_weight_sigma = used > 4 ? std::sqrt(wssr / (used - 4)) : 1.0;
    sol.valid = true;
    // Horizontal velocity DOP from the unweighted geometry (as the position's HDOP).
    Eigen::Matrix4d hth = Eigen::Matrix4d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      Eigen::Vector4d h;
      h << -(frame.enu_from_ecef * obs[i].los_ecef), 1.0;
      hth += h * h.transpose();
    }
    const Eigen::Matrix4d q = hth.ldlt().solve(Eigen::Matrix4d::Identity());
    sol.hdop = std::sqrt(std::max(0.0, q(0, 0) + q(1, 1)));
    if (worst <= exclusion_sigmas || used - 1 < min_used || pass == max_exclusions) break;
    active[worst_i] = false;
    ++sol.excluded;
  }
  return sol;
}

}  // namespace v2xloc::sim::gnss
