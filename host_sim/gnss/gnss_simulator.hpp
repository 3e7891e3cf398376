// GNSS at pseudo-range level in an urban canyon: a moving GPS + Galileo constellation, line of sight
// and facade reflections from the world's RayCaster, atmosphere, receiver clock and noise, and a
// receiver-style weighted least-squares fix with DOPs and a reported accuracy.
//
// Error model per satellite i (metres), pseudo-range rho_i = |sat - rx| + c*dt_rx + e_i:
//   e_i = SISRE_i (Gauss-Markov) + I_i (40.3 TEC / f^2, single-layer slant mapping; the receiver
//         removes a broadcast-model share) + T_i (Saastamoinen; receiver model error) +
//         multipath (paper eq. 1: dd = sum_k a_k (d_k - d_0 + phi_k)) smoothed by the receiver's
//         code-carrier filter + white code noise scaled by C/N0.
// Direct path blocked: tracked through the strongest facade reflection (NLOS, full excess delay,
// lower C/N0), or lost when no reflection reaches the antenna.
// Doppler per satellite as a range rate: u . (v_sat - v_rx) + clock drift + noise scaled by C/N0;
// an NLOS signal's rate is that of the mirrored antenna, u . v_sat - d . v_rx with d the reflected
// arrival direction (no error when driving parallel to the facade, 2 (v.n)(u.n) towards it).
// Velocity fix: weighted least squares with residual-based exclusion (receiver FDE).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "host_sim/common/rng.hpp"
#include "host_sim/world/ray_caster.hpp"
#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::sim {

namespace gnss {
struct PseudorangeObservation;
struct RangeRateObservation;
struct ReflectedPath;
}  // namespace gnss

struct GnssConfig {
  // Constellation (circular Walker-like orbits, propagated in time; Earth rotation included).
  int gps_planes = 6, gps_per_plane = 5;          // 30 GPS, r = 26560 km, i = 55 deg
  int galileo_planes = 3, galileo_per_plane = 8;  // 24 Galileo, r = 29600 km, i = 56 deg
  double epoch_offset_s = 0.0;     // shifts the constellation snapshot (t = 0 of the scenario)
  int max_tracked_satellites = 16; // receiver channels used for the fix (highest elevation first)
  double elevation_mask_deg = 5.0;   // consumer default (admits low, often NLOS, signals)

  // Signal (GPS L1 C/A and Galileo E1 share the carrier).
  double carrier_hz = 1575.42e6;

  // Ionosphere: true vertical TEC vs. the receiver's broadcast model (Klobuchar removes ~50-60%).
  double vtec_tecu = 25.0;               // 1 TECU = 1e16 electrons/m^2
  double vtec_model_fraction = 0.55;     // share of the true TEC the receiver's model predicts
  double iono_gradient_sigma = 0.15;     // per-satellite relative TEC variation (Gauss-Markov)
  double iono_tau_s = 600.0;
  double iono_shell_height_m = 350e3;

  // Troposphere: Saastamoinen zenith delay; the receiver assumes a standard atmosphere.
  double pressure_hpa = 1013.25, temperature_k = 291.15, relative_humidity = 0.6;
  double tropo_model_error_sigma = 0.05; // relative zenith-delay error of the receiver's model

  // Satellite orbit + clock error (signal-in-space range error).
  double sisre_sigma_m = 0.7, sisre_tau_s = 1800.0;

  // Multipath / NLOS.
  double reflection_amplitude = 0.6;     // facade reflection coefficient (a_k upper bound)
  double reflection_loss_db = 6.0;       // C/N0 loss of a reflected-only (NLOS) signal
  double probe_azimuth_step_deg = 5.0;   // horizontal probe rays that discover facades
  double max_facade_distance_m = 120.0;
  double multipath_smoothing_tau_s = 2.0;  // receiver code-carrier smoothing (Hatch-like)

  // Receiver.
  double cn0_zenith_dbhz = 47.0;         // C/N0 of an unobstructed zenith signal
  double code_noise_m_at_45dbhz = 0.4;   // white code noise sigma at 45 dB-Hz
  double clock_bias_initial_m = 3.0e4;   // c * dt at t = 0
  double clock_drift_mps = 1.5;          // c * ddt/dt
  double clock_drift_random_walk = 0.05; // m/s per sqrt(s)
  double sigma_uere_m = 3.0;             // what the receiver believes its range error is
  // Low-cost automotive receivers weight by elevation only: an NLOS signal's C/N0 loss then does not
  // reduce its weight in the fix (true = RTKLIB-style C/N0 weighting, a survey-grade receiver).
  bool cn0_weighting = false;
  int max_lsq_iterations = 10;
  double doppler_noise_mps_at_45dbhz = 0.05;  // white range-rate noise (PLL/FLL), C/N0 scaled
  double sigma_doppler_uere_mps = 0.1;        // what the receiver believes its range-rate error is
  double doppler_exclusion_sigmas = 4.0;      // FDE: normalized residual that drops a satellite
};

struct GnssFix {
  double t = 0.0;
  double lat_deg = 0.0, lon_deg = 0.0, alt_m = 0.0;
  double h_acc_m = 0.0, v_acc_m = 0.0;   // reported (sigma_uere * DOP), understates multipath
  int num_sats = 0;                       // used in the fix
  double hdop = 0.0, pdop = 0.0;
  bool valid = false;
  // Doppler velocity (ENU, m/s) and its reported accuracy (sigma_doppler_uere * velocity HDOP,
  // inflated by the a-posteriori unit-weight sigma when the range rates disagree).
  double vel_east = 0.0, vel_north = 0.0, vel_up = 0.0;
  double speed_acc_mps = 0.0;
  bool velocity_valid = false;
  // Truth-side diagnostics for tests (not on the wire):
  Eigen::Vector3d enu_estimate = Eigen::Vector3d::Zero();
  int num_visible = 0;   // above the elevation mask (before blocking)
  int num_nlos = 0;      // tracked through a reflection only
  int num_blocked = 0;   // lost: blocked with no reflection
  int num_velocity_excluded = 0;  // range rates dropped by the velocity fix's residual test
};

class GnssSimulator {
 public:
  GnssSimulator(const GnssConfig& config, const RayCaster& world, const v2xloc::GeodeticOrigin& origin,
                std::uint64_t seed);
  // Fix at time t (seconds, increasing) for the true antenna position and velocity in the world's
  // ENU frame.
  GnssFix fix(double t, const Eigen::Vector3d& antenna_enu, const Eigen::Vector3d& antenna_velocity_enu);

 private:
  struct Satellite {
    int prn = 0;
    bool galileo = false;
    double radius_m = 0.0, inclination_rad = 0.0, raan_rad = 0.0, phase_rad = 0.0,
           mean_motion_rps = 0.0;
    double sisre_m = 0.0;            // Gauss-Markov orbit + clock error
    double iono_rel = 0.0;           // Gauss-Markov relative TEC deviation along this line of sight
    double multipath_smoothed_m = 0.0;
    bool tracked_before = false;
  };
  struct Facade {                    // a reflecting plane found by the probe rays
    Eigen::Vector3d point, normal;   // normal points towards the street (the antenna side)
    int object_id = -1;
  };

  void propagate_errors(double dt);
  Eigen::Vector3d satellite_ecef(const Satellite& sat, double t) const;
  Eigen::Vector3d satellite_velocity_ecef(const Satellite& sat, double t) const;
  void discover_facades(const Eigen::Vector3d& antenna_enu);
  struct Reflection {
    double excess_m = 0.0;           // extra path length over the direct one
    Eigen::Vector3d arrival_dir;     // ENU direction the reflected signal arrives from
  };
  // Specular facade reflections that reach the antenna from direction los.
  void find_reflections(const Eigen::Vector3d& antenna_enu, const Eigen::Vector3d& los,
                        std::vector<Reflection>& out) const;
  // The steps of fix(), in order (gnss_simulator.cpp).
  struct Epoch;
  struct Candidate;
  struct SignalPath;
  Epoch begin_epoch(double t, const Eigen::Vector3d& antenna_enu, const Eigen::Vector3d& antenna_velocity_enu);
  void visible_satellites(const Epoch& e, std::vector<Candidate>& visible);
  bool signal_path(const Epoch& e, const Candidate& c, std::vector<gnss::ReflectedPath>& paths, SignalPath& out,
                   GnssFix& fix);
  void observe(const Epoch& e, const Candidate& c, const SignalPath& path, gnss::PseudorangeObservation& pr,
               gnss::RangeRateObservation& rr);
  void solve(const std::vector<gnss::PseudorangeObservation>& obs, std::vector<gnss::RangeRateObservation>& rates,
             GnssFix& out);

  GnssConfig cfg_;
  const RayCaster& world_;
  v2xloc::GeodeticOrigin origin_;
  Rng rng_;
  Rng doppler_rng_;  // own stream: adding Doppler left the position errors' draws unchanged
  std::vector<Satellite> sats_;
  std::vector<Facade> facades_;
  std::vector<Reflection> reflections_;
  double last_t_ = 0.0;
  double tropo_true_scale_ = 1.0;  // true zenith delay / receiver's model (drawn per run)
  bool started_ = false;
  double clock_bias_m_ = 0.0, clock_drift_mps_ = 0.0;
  Eigen::Vector4d last_solution_ = Eigen::Vector4d::Zero();  // ECEF xyz + clock
  bool have_solution_ = false;
};

}  // namespace v2xloc::sim
