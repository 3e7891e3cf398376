#include "host_sim/gnss/gnss_simulator.hpp"

#include <algorithm>
#include <cmath>

#include "host_sim/gnss/gnss_models.hpp"
#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::sim {
namespace {

constexpr double kDegToRad = det::kPi / 180.0;
constexpr double kGpsOrbitRadius = 26559.7e3;      // m, semi-major axis (circular)
constexpr double kGalileoOrbitRadius = 29599.8e3;  // m
constexpr double kRayStartLift = 0.05;             // m, keeps the antenna off its own mount
constexpr double kSkyRayRange = 2000.0;            // m, beyond the world's tallest geometry
constexpr double kFacadeHitTolerance = 0.3;        // m, reflection ray must end on the facade
constexpr double kCn0ElevationSpanDb = 12.0;       // zenith-to-horizon C/N0 drop (antenna gain)

// Receiver's a-priori sigma: elevation and C/N0 weighting (in the spirit of RTKLIB's model).
double apriori_sigma(double sigma_uere, double sin_el, double cn0_dbhz) {
  const double cn0_factor = std::pow(10.0, (45.0 - cn0_dbhz) / 20.0);
  return sigma_uere * std::sqrt(0.5 + 0.5 / (sin_el * sin_el)) * cn0_factor;
}

}  // namespace

GnssSimulator::GnssSimulator(const GnssConfig& config, const RayCaster& world,
                             const v2xloc::GeodeticOrigin& origin, std::uint64_t seed)
    : cfg_(config), world_(world), origin_(origin), rng_(derive_seed(seed, {0x474E5353ull})),  // "GNSS"
      doppler_rng_(derive_seed(seed, {0x444F50ull})) {                                  // "DOP"
  // Walker-like constellations: planes evenly spaced in RAAN, satellites evenly in argument of
  // latitude with a per-plane phase offset (GPS 24/6, Galileo Walker 24/3/1).
  auto add_constellation = [&](bool galileo, int planes, int per_plane, double radius, double incl_deg,
                               int prn_base) {
    for (int p = 0; p < planes; ++p) {
      for (int k = 0; k < per_plane; ++k) {
        Satellite s;
        s.prn = prn_base + p * per_plane + k;
        s.galileo = galileo;
        s.radius_m = radius;
        s.inclination_rad = incl_deg * kDegToRad;
        s.raan_rad = 2.0 * det::kPi * p / planes + (galileo ? 0.35 : 0.0);
        s.phase_rad = 2.0 * det::kPi * k / per_plane + 2.0 * det::kPi * p / (planes * per_plane);
        s.mean_motion_rps = std::sqrt(gnss::kEarthGm / (radius * radius * radius));
        s.sisre_m = rng_.gaussian(cfg_.sisre_sigma_m);
        s.iono_rel = rng_.gaussian(cfg_.iono_gradient_sigma);
        sats_.push_back(s);
      }
    }
  };
  add_constellation(false, cfg_.gps_planes, cfg_.gps_per_plane, kGpsOrbitRadius, 55.0, 1);
  add_constellation(true, cfg_.galileo_planes, cfg_.galileo_per_plane, kGalileoOrbitRadius, 56.0, 201);
  tropo_true_scale_ = 1.0 + rng_.gaussian(cfg_.tropo_model_error_sigma);
  clock_bias_m_ = cfg_.clock_bias_initial_m;
  clock_drift_mps_ = cfg_.clock_drift_mps;
  last_solution_ << origin_.ecef, 0.0;  // the receiver's last known position: the area it is in
}

Eigen::Vector3d GnssSimulator::satellite_ecef(const Satellite& sat, double t) const {
  const double time = t + cfg_.epoch_offset_s;
  const double u = sat.phase_rad + sat.mean_motion_rps * time;
  const double raan = sat.raan_rad - gnss::kEarthRotationRate * time;  // inertial -> Earth-fixed
  const double cu = det::cos(u), su = det::sin(u);
  const double co = det::cos(raan), so = det::sin(raan);
  const double ci = det::cos(sat.inclination_rad), si = det::sin(sat.inclination_rad);
  return sat.radius_m * Eigen::Vector3d(cu * co - su * so * ci, cu * so + su * co * ci, su * si);
}

// Central difference of the orbit model (the receiver gets the same from the broadcast ephemeris).
Eigen::Vector3d GnssSimulator::satellite_velocity_ecef(const Satellite& sat, double t) const {
  constexpr double kHalfStep = 0.5;  // s
  return (satellite_ecef(sat, t + kHalfStep) - satellite_ecef(sat, t - kHalfStep)) / (2.0 * kHalfStep);
}

void GnssSimulator::propagate_errors(double dt) {
  for (Satellite& s : sats_) {
    s.sisre_m = gnss::gauss_markov_step(s.sisre_m, cfg_.sisre_sigma_m, cfg_.sisre_tau_s, dt, rng_.gaussian());
    s.iono_rel = gnss::gauss_markov_step(s.iono_rel, cfg_.iono_gradient_sigma, cfg_.iono_tau_s, dt, rng_.gaussian());
  }
  // Receiver clock: bias integrates the drift, the drift random-walks (TCXO).
  clock_bias_m_ += clock_drift_mps_ * dt;
  clock_drift_mps_ += cfg_.clock_drift_random_walk * std::sqrt(dt) * rng_.gaussian();
}

void GnssSimulator::discover_facades(const Eigen::Vector3d& antenna_enu) {
  facades_.clear();
  const int steps = std::max(4, static_cast<int>(std::lround(360.0 / cfg_.probe_azimuth_step_deg)));
  const Eigen::Vector3d start = antenna_enu + Eigen::Vector3d(0, 0, kRayStartLift);
  for (int i = 0; i < steps; ++i) {
    const double az = 2.0 * det::kPi * i / steps;
    const Eigen::Vector3d dir(det::sin(az), det::cos(az), 0.0);
    RayHit hit;
    if (!world_.cast(start, dir, cfg_.max_facade_distance_m, hit)) continue;
    if (std::abs(hit.normal.z()) > 0.3) continue;  // only (near) vertical reflectors
    Eigen::Vector3d n = hit.normal;
    if (n.dot(dir) > 0.0) n = -n;                  // face the antenna
    const Eigen::Vector3d point = start + hit.range * dir;
    bool known = false;
    for (const Facade& f : facades_) {
      if (f.object_id == hit.object_id && f.normal.dot(n) > 0.999 && std::abs((point - f.point).dot(n)) < 0.5) {
        known = true;
        break;
      }
    }
    if (!known) facades_.push_back({point, n, hit.object_id});
  }
}

void GnssSimulator::find_reflections(const Eigen::Vector3d& antenna_enu, const Eigen::Vector3d& los,
                                     std::vector<Reflection>& out) const {
  out.clear();
  const Eigen::Vector3d start = antenna_enu + Eigen::Vector3d(0, 0, kRayStartLift);
  for (const Facade& f : facades_) {
    const double s_dot_n = los.dot(f.normal);
    if (s_dot_n <= 1e-3) continue;                  // satellite behind the facade
    const double h = (start - f.point).dot(f.normal);
    if (h <= 0.0) continue;
    // The signal arrives from the mirror image of the satellite direction; the ray must end on this
    // facade (not before it, not above its roof), and the facade point must see the satellite.
    const Eigen::Vector3d d = los - 2.0 * s_dot_n * f.normal;
    const double range = h / s_dot_n;
    RayHit hit;
    if (!world_.cast(start, d, range + kFacadeHitTolerance, hit)) continue;
    if (std::abs(hit.range - range) > kFacadeHitTolerance || std::abs(hit.normal.dot(f.normal)) < 0.99) continue;
    const Eigen::Vector3d bounce = start + hit.range * d + 0.01 * f.normal;
    RayHit sky;
    if (world_.cast(bounce, los, kSkyRayRange, sky)) continue;
    out.push_back({2.0 * h * s_dot_n, d});          // image-antenna geometry: 2 h cos(incidence)
  }
}

// What one fix's observations share: the receiver's true position and motion, the atmosphere's true
// and modelled zenith delays and the code-carrier smoothing gain for the time since the last fix.
struct GnssSimulator::Epoch {
  double t = 0.0;
  Eigen::Vector3d antenna_enu, antenna_velocity_enu, rx_ecef;
  double wavelength = 0.0, zenith_model = 0.0, zenith_true = 0.0, smoothing = 1.0;
};

struct GnssSimulator::Candidate {
  std::size_t index;
  Eigen::Vector3d sat_ecef, los_enu;
  double elevation;
};

// The signal the receiver tracks from one satellite: its multipath delay, C/N0 and the direction
// it arrives from (the line of sight, or the reflection's for NLOS).
struct GnssSimulator::SignalPath {
  double error_m = 0.0;
  double cn0 = 0.0;
  Eigen::Vector3d arrival;
};

GnssSimulator::Epoch GnssSimulator::begin_epoch(double t, const Eigen::Vector3d& antenna_enu,
                                                const Eigen::Vector3d& antenna_velocity_enu) {
  const double dt = started_ ? t - last_t_ : 0.0;
  if (dt > 0.0) propagate_errors(dt);
  started_ = true;
  last_t_ = t;
  Epoch e;
  e.t = t;
  e.antenna_enu = antenna_enu;
  e.antenna_velocity_enu = antenna_velocity_enu;
  e.rx_ecef = v2xloc::enu_to_ecef(origin_, antenna_enu);
  const double lat_rad = origin_.geodetic.lat_deg * kDegToRad;
  e.wavelength = gnss::kSpeedOfLight / cfg_.carrier_hz;
  e.zenith_model = gnss::saastamoinen_zenith_m(1013.25, 288.15, 0.5, lat_rad, origin_.geodetic.alt_m);
  e.zenith_true = tropo_true_scale_ *
      gnss::saastamoinen_zenith_m(cfg_.pressure_hpa, cfg_.temperature_k, cfg_.relative_humidity, lat_rad,
                                  origin_.geodetic.alt_m);
  e.smoothing = dt > 0.0 ? 1.0 - std::exp(-dt / cfg_.multipath_smoothing_tau_s) : 1.0;
  return e;
}

// Satellites above the mask, highest first, limited by the receiver's channels.
void GnssSimulator::visible_satellites(const Epoch& e, std::vector<Candidate>& visible) {
  visible.clear();
  for (std::size_t i = 0; i < sats_.size(); ++i) {
    const Eigen::Vector3d sat = satellite_ecef(sats_[i], e.t);
    const Eigen::Vector3d los = v2xloc::ecef_delta_to_enu(origin_, sat - e.rx_ecef).normalized();
    const double el = det::asin(std::clamp(los.z(), -1.0, 1.0));
    if (el >= cfg_.elevation_mask_deg * kDegToRad) visible.push_back({i, sat, los, el});
    else sats_[i].tracked_before = false;
  }
  std::sort(visible.begin(), visible.end(), [](const Candidate& a, const Candidate& b) {
    return a.elevation > b.elevation || (a.elevation == b.elevation && a.index < b.index);
  });
  if (static_cast<int>(visible.size()) > cfg_.max_tracked_satellites) visible.resize(static_cast<std::size_t>(cfg_.max_tracked_satellites));
}

// Line of sight or facade reflections; false (and the satellite lost) when the direct path is
// blocked and no reflection reaches the antenna.
bool GnssSimulator::signal_path(const Epoch& e, const Candidate& c, std::vector<gnss::ReflectedPath>& paths,
                                SignalPath& out, GnssFix& fix) {
  const double sin_el = det::sin(c.elevation);
  const Eigen::Vector3d start = e.antenna_enu + Eigen::Vector3d(0, 0, kRayStartLift);
  RayHit block;
  const bool los_clear = !world_.cast(start, c.los_enu, kSkyRayRange, block);
  find_reflections(e.antenna_enu, c.los_enu, reflections_);
  out.cn0 = cfg_.cn0_zenith_dbhz - kCn0ElevationSpanDb * (1.0 - sin_el);
  paths.clear();
  out.error_m = 0.0;
  out.arrival = c.los_enu;
  if (los_clear) {
    // Multipath on a line-of-sight signal, paper eq. 1. a_k: the facade's reflection coefficient
    // scaled by the correlator's in-phase share (1 + cos theta_k) / 2, theta_k the carrier phase
    // of the reflected path; phi_k: the reflection's half-cycle phase shift as range (lambda / 2).
    for (const Reflection& r : reflections_) {
      const double excess = r.excess_m;
      const double theta = 2.0 * det::kPi * excess / e.wavelength + det::kPi;
      const double a = std::clamp(cfg_.reflection_amplitude * 0.5 * (1.0 + det::cos(theta)), 1e-3, 1.0);
      paths.push_back({a, excess, 0.5 * e.wavelength});
    }
    out.error_m = gnss::multipath_delay_m(paths.data(), paths.size());
    return true;
  }
  if (reflections_.empty()) {
    ++fix.num_blocked;
    sats_[c.index].tracked_before = false;
    return false;
  }
  // NLOS: the receiver tracks the shortest reflection alone (a = 1 in eq. 1), weaker signal.
  const Reflection& shortest = *std::min_element(
      reflections_.begin(), reflections_.end(),
      [](const Reflection& a, const Reflection& b) { return a.excess_m < b.excess_m; });
  out.arrival = shortest.arrival_dir;
  paths.push_back({1.0, shortest.excess_m, 0.5 * e.wavelength});
  out.error_m = gnss::multipath_delay_m(paths.data(), paths.size());
  out.cn0 -= cfg_.reflection_loss_db - 20.0 * std::log10(std::max(cfg_.reflection_amplitude, 1e-3));
  ++fix.num_nlos;
  return true;
}

// The tracked signal's pseudorange (smoothed multipath and code noise, satellite, atmosphere and
// clock errors; corrected by the receiver's own atmosphere models) and range rate (the satellite's
// motion along the true line of sight, the antenna's along the arrival direction, the clock drift,
// tracking-loop noise).
void GnssSimulator::observe(const Epoch& e, const Candidate& c, const SignalPath& path,
                            gnss::PseudorangeObservation& pr, gnss::RangeRateObservation& rr) {
  Satellite& sat = sats_[c.index];
  const double sin_el = det::sin(c.elevation);
  const double noise_sigma = cfg_.code_noise_m_at_45dbhz * std::pow(10.0, (45.0 - path.cn0) / 20.0);
  const double raw_error = path.error_m + noise_sigma * rng_.gaussian();
  // Code-carrier smoothing: the receiver low-passes code noise and multipath (time correlation).
  sat.multipath_smoothed_m = sat.tracked_before
                                 ? sat.multipath_smoothed_m + e.smoothing * (raw_error - sat.multipath_smoothed_m)
                                 : raw_error;
  sat.tracked_before = true;

  const double iono_true = gnss::iono_delay_m(cfg_.vtec_tecu * gnss::kTecUnit * (1.0 + sat.iono_rel), cfg_.carrier_hz) *
                           gnss::iono_slant_factor(c.elevation, cfg_.iono_shell_height_m);
  const double iono_model = gnss::iono_delay_m(cfg_.vtec_model_fraction * cfg_.vtec_tecu * gnss::kTecUnit, cfg_.carrier_hz) *
                            gnss::iono_slant_factor(c.elevation, cfg_.iono_shell_height_m);
  const double mapping = gnss::tropo_mapping(c.elevation);
  const double geometric = (c.sat_ecef - e.rx_ecef).norm();
  const double pseudorange = geometric + clock_bias_m_ + sat.sisre_m + iono_true + e.zenith_true * mapping +
                             sat.multipath_smoothed_m;
  pr.sat_ecef = c.sat_ecef;
  pr.pseudorange_m = pseudorange - iono_model - e.zenith_model * mapping;
  pr.sigma_m = apriori_sigma(cfg_.sigma_uere_m, sin_el, cfg_.cn0_weighting ? path.cn0 : 45.0);

  const Eigen::Vector3d u_ecef = (c.sat_ecef - e.rx_ecef).normalized();
  const Eigen::Vector3d sat_vel = satellite_velocity_ecef(sat, e.t);
  const double rate_noise = cfg_.doppler_noise_mps_at_45dbhz * std::pow(10.0, (45.0 - path.cn0) / 20.0);
  rr.sat_vel_ecef = sat_vel;
  rr.range_rate_mps = u_ecef.dot(sat_vel) - path.arrival.dot(e.antenna_velocity_enu) + clock_drift_mps_ +
                      rate_noise * doppler_rng_.gaussian();
  rr.sigma_mps = apriori_sigma(cfg_.sigma_doppler_uere_mps, sin_el, cfg_.cn0_weighting ? path.cn0 : 45.0);
}

// The receiver's position fix (weighted least squares from its last solution) and, on it, the
// velocity fix with residual-based exclusion.
void GnssSimulator::solve(const std::vector<gnss::PseudorangeObservation>& obs,
                          std::vector<gnss::RangeRateObservation>& rates, GnssFix& out) {
  out.num_sats = static_cast<int>(obs.size());
  if (obs.size() < 4) return;
  Eigen::Vector4d initial = last_solution_;
  if (!have_solution_) initial(3) = 0.0;
  const gnss::WlsSolution sol = gnss::solve_position_wls(obs, initial, cfg_.max_lsq_iterations, origin_);
  if (!sol.converged) return;
  last_solution_ = sol.state;
  have_solution_ = true;
  const auto geo = v2xloc::ecef_to_geodetic(sol.state.head<3>());
  out.lat_deg = geo.point.lat_deg;
  out.lon_deg = geo.point.lon_deg;
  out.alt_m = geo.point.alt_m;
  out.hdop = sol.hdop;
  out.pdop = sol.pdop;
  out.h_acc_m = cfg_.sigma_uere_m * sol.hdop;
  out.v_acc_m = cfg_.sigma_uere_m * sol.vdop;
  out.enu_estimate = v2xloc::ecef_to_enu(origin_, sol.state.head<3>());
  out.valid = geo.status != v2xloc::GeodesyStatus::kInvalidInput && sol.pdop < 50.0;

  // Velocity: line-of-sight vectors from the receiver's own position solution.
  for (std::size_t i = 0; i < rates.size(); ++i) {
    rates[i].los_ecef = (obs[i].sat_ecef - sol.state.head<3>()).normalized();
  }
  const gnss::VelocitySolution vel = gnss::solve_velocity_wls(rates, origin_, cfg_.doppler_exclusion_sigmas);
  out.num_velocity_excluded = vel.excluded;
  if (out.valid && vel.valid) {
    out.vel_east = vel.vel_enu.x();
    out.vel_north = vel.vel_enu.y();
    out.vel_up = vel.vel_enu.z();
    // Reported accuracy: DOP times the a-priori sigma, inflated by the fit's residuals (a receiver
    // sees inconsistent range rates even when it cannot tell which one is reflected).
    out.speed_acc_mps = cfg_.sigma_doppler_uere_mps * vel.hdop * std::max(1.0, vel.unit_weight_sigma);
    out.velocity_valid = true;
  }
}

GnssFix GnssSimulator::fix(double t, const Eigen::Vector3d& antenna_enu, const Eigen::Vector3d& antenna_velocity_enu) {
  const Epoch e = begin_epoch(t, antenna_enu, antenna_velocity_enu);
  GnssFix out;
  out.t = t;
  discover_facades(antenna_enu);
  std::vector<Candidate> visible;
  visible_satellites(e, visible);
  out.num_visible = static_cast<int>(visible.size());

  std::vector<gnss::PseudorangeObservation> obs;
  std::vector<gnss::ReflectedPath> paths;
  std::vector<gnss::RangeRateObservation> rates;
  for (const Candidate& c : visible) {
    SignalPath path;
    if (!signal_path(e, c, paths, path, out)) continue;
    observe(e, c, path, obs.emplace_back(), rates.emplace_back());
  }
  solve(obs, rates, out);
  return out;
}

}  // namespace v2xloc::sim
