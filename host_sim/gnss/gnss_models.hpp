// The physics and the receiver maths of the GNSS simulator, as small pure functions so each can be
// tested on its own: atmosphere, multipath (paper eq. 1), Gauss-Markov errors, weighted least squares.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::sim::gnss {

inline constexpr double kSpeedOfLight = 299792458.0;          // m/s
inline constexpr double kEarthRotationRate = 7.2921151467e-5;  // rad/s (WGS84)
inline constexpr double kEarthGm = 3.986004418e14;             // m^3/s^2
inline constexpr double kTecUnit = 1e16;                       // electrons/m^2 per TECU

// Ionospheric group delay (paper: dd_ion = 40.3 TEC / f^2), TEC in electrons/m^2, f in Hz -> metres.
double iono_delay_m(double tec_el_per_m2, double carrier_hz);
// Single-layer slant factor 1/cos(z') with sin(z') = R cos(el) / (R + h_shell) (IS-GPS-200 style).
double iono_slant_factor(double elevation_rad, double shell_height_m);

// Saastamoinen (1972) zenith delay, hydrostatic + wet, pressure hPa, temperature K, humidity 0..1.
double saastamoinen_zenith_m(double pressure_hpa, double temperature_k, double relative_humidity,
                             double latitude_rad, double height_m);
// A simple elevation mapping, 1.001 / sqrt(0.002001 + sin^2(el)) (finite at the horizon).
double tropo_mapping(double elevation_rad);

// One reflected path of paper eq. 1: attenuation a_k in (0, 1], excess path d_k - d_0 and the
// range-equivalent phase shift phi_k, both in metres.
struct ReflectedPath {
  double attenuation = 0.0;
  double excess_m = 0.0;
  double phase_m = 0.0;
};
// dd_mult = sum_k a_k (d_k - d_0 + phi_k)  (paper eq. 1).
double multipath_delay_m(const ReflectedPath* paths, std::size_t count);

// First-order Gauss-Markov step with stationary sigma and correlation time tau.
double gauss_markov_step(double x, double sigma, double tau_s, double dt_s, double white_unit);

struct PseudorangeObservation {
  Eigen::Vector3d sat_ecef;
  double pseudorange_m = 0.0;  // already corrected by the receiver's atmosphere models
  double sigma_m = 1.0;        // a-priori sigma (elevation and C/N0 weighting)
};

struct WlsSolution {
  Eigen::Vector4d state = Eigen::Vector4d::Zero();  // ECEF x, y, z, c*dt
  double hdop = 0.0, vdop = 0.0, pdop = 0.0;
  int iterations = 0;
  bool converged = false;
};

// Gauss-Newton weighted least squares for position + clock; DOPs from the unweighted geometry in
// the local ENU frame (as receivers report them).
WlsSolution solve_position_wls(const std::vector<PseudorangeObservation>& obs,
                               const Eigen::Vector4d& initial, int max_iterations,
                               const v2xloc::GeodeticOrigin& frame);

// One Doppler measurement as a range rate (m/s): d/dt of the pseudorange, i.e. the projection of
// the satellite-receiver relative velocity on the line of sight plus the receiver clock drift.
struct RangeRateObservation {
  Eigen::Vector3d los_ecef;       // unit vector receiver -> satellite (from the receiver's fix)
  Eigen::Vector3d sat_vel_ecef;   // broadcast-ephemeris satellite velocity
  double range_rate_mps = 0.0;
  double sigma_mps = 0.1;         // a-priori sigma (same weighting model as the code)
};

struct VelocitySolution {
  Eigen::Vector3d vel_enu = Eigen::Vector3d::Zero();
  double clock_drift_mps = 0.0;
  double hdop = 0.0;              // velocity DOP of the used geometry (horizontal)
  double unit_weight_sigma = 1.0; // a-posteriori: sqrt(weighted residual sum / (used - 4)), 1 if used = 4
  int used = 0, excluded = 0;     // observations in the solution / dropped by the residual test
  bool valid = false;
};

// Weighted least squares for receiver velocity + clock drift (linear: one solve), with receiver-
// style fault exclusion: while the largest normalized residual exceeds exclusion_sigmas and more
// than min_used observations remain, drop it and solve again (at most max_exclusions times).
VelocitySolution solve_velocity_wls(const std::vector<RangeRateObservation>& obs,
                                    const v2xloc::GeodeticOrigin& frame, double exclusion_sigmas = 4.0,
                                    int max_exclusions = 3, int min_used = 5);

}  // namespace v2xloc::sim::gnss
