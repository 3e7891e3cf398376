// Localizer wiring (see localizer.hpp for the data flow). on_ego_scan runs the stages in order:
// scan preparation -> odometry -> filter prediction -> map refresh -> registration (tracking or
// start-up search) -> validity gate and EKF (pose filter) -> output -> fixed-lag revisions.
#include "v2xloc/algo/localization/localizer.hpp"

#include <cmath>

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

void Localizer::configure(const LocalizerParams& params, const GeodeticOrigin& origin) {
  params_ = params;
  origin_ = origin;
  counters_ = {};
  output_ = {};
  backfill_.reset();
  frame_ = 0;
  last_frame_t_ = 0.0;
  have_frame_ = false;
  last_odometry_t_ = 0.0;
  have_odometry_frame_ = false;
  vehicle_ = {};
  gnss_ = {};
  course_.configure(params.course);
  odom_T_body_ = Pose3d::Identity();
  have_input_t_ = false;
  latest_input_t_ = 0.0;
  imu_.configure(params.filter.imu);
  scan_.configure(params.scan, params.use_vehicle_signals);
  odometry_.configure(params.odometry);
  odometry_.reset();
  map_.configure(params.map, params.tracking.icp.max_correspondence_distance);
  work_.configure(params.work);
  tracking_forecast_ = 0.0;
  rebuild_deferred_ = 0;
  filter_.configure(params.filter, params.use_vehicle_signals);
  startup_.configure(params.startup, params.tracking.icp, params.filter.ekf.gates.gnss_sigma_inflation);
  tracking_.configure(params.tracking, params.audit, params.startup.search);
  frame_output_.configure(params.output);
}

void Localizer::on_vehicle(const VehicleInput& in) {
  if (!std::isfinite(in.t) || !std::isfinite(in.wheel_speed) || !std::isfinite(in.yaw_rate)) return;
  vehicle_.valid = true;
  vehicle_.speed = in.wheel_speed;
  vehicle_.yaw_rate = in.yaw_rate;
  note_input_time(in.t);
  filter_.on_vehicle(in.t, in.wheel_speed, in.yaw_rate);
}

// Checked and averaged by the intake (imu_intake.hpp); each ~10 ms mean gyro z goes to the filter.
void Localizer::on_imu(const ImuInput& in) {
  ++counters_.imu_received;
  const GyroMeasurement g = imu_.push(in, have_input_t_, latest_input_t_, counters_);
  if (g.ready) filter_.on_gyro(g.t, g.rate, g.span, counters_);
}

void Localizer::on_gnss(const GnssInput& in) {
  ++counters_.gnss_received;
  if (!in.valid || !std::isfinite(in.lat_deg) || !std::isfinite(in.lon_deg) ||
      !std::isfinite(in.alt_m) || !(in.h_acc > 0.0) || !(in.v_acc > 0.0) || !std::isfinite(in.t)) {
    ++counters_.gnss_invalid;
    return;
  }
  note_input_time(in.t);
  gnss_.valid = true;
  gnss_.enu = geodetic_to_enu(origin_, GeodeticPoint{in.lat_deg, in.lon_deg, in.alt_m});
  gnss_.sigma = in.h_acc;
  if (course_.update(in, vehicle_)) ++counters_.gnss_headings;
  if (filter_.on_gnss(in.t, gnss_.enu, in.h_acc, in.v_acc) == GnssFusion::kDiverged) lose_track();
}

MapInsertResult Localizer::on_map_cloud(const MapCloudInput& in) {
  const MapInsertResult r = map_.insert(in);
  if (r.status == MapInsertStatus::kPaced) ++counters_.map_clouds_paced;
  // Clouds that went through staging and a check (a background refusal is priced as a whole cloud:
  // rare, and the budget errs towards deferring)
  const bool checked = r.status == MapInsertStatus::kInserted || r.status == MapInsertStatus::kReplaced ||
                       r.status == MapInsertStatus::kRejectedInconsistent || r.status == MapInsertStatus::kHeldBack ||
                       r.status == MapInsertStatus::kBackgroundMismatch;
  if (checked) {
    const PeriodWorkParams& w = params_.work;
    work_.add(w.map_cloud_point * (r.input_points - r.input_thinned) + r.units_vetted * w.map_vetting + (r.cells_rebuilt ? w.cells_rebuild : 0.0) +
              (r.background_checked ? w.background_check : 0.0));
  }
  return r;
}

const LocalizerFrameOutput& Localizer::on_ego_scan(const EgoScanInput& in) {
  output_ = {};
  output_.frame = frame_;
  output_.t = in.t;
  ++counters_.frames;
  if (std::isfinite(in.t) && (!have_frame_ || in.t > last_frame_t_)) {
    note_input_time(in.t);
    probe_(LocalizerStage::kScanPrep);
    // Priced per pass: a sweep over the ingest capacity is read again coarser.
    const std::uint32_t passes = scan_.prepare(in, deskew_motion(in.t), counters_.scan_points_dropped, counters_.scans_coarsened);
    work_.add(params_.work.scan * passes);
    if (params_.use_stereo && !in.stereo.disparity.empty()) scan_.prepare_stereo(in.stereo);
    probe_(LocalizerStage::kOdometry);
    // A sweep without points has nothing to register: the odometry and the start-up search's
    // hypotheses wait for the next sweep with points, as if this one had not come.
    const bool has_points = !scan_.deskewed().empty();
    if (has_points) run_odometry(in);
    output_.odometry_pose = odom_T_body_;
    probe_(LocalizerStage::kFusion);
    if (has_points) startup_.on_frame(output_.odometry_ok, odom_T_body_, gnss_);
    filter_.predict_to(in.t);
    probe_(LocalizerStage::kMapRefresh);
    LazyNormalCounters normals;
    const PeriodWorkParams& w = params_.work;
    const double step = w.rebuild_step + (map_.next_step_activates() ? w.activation : 0.0);
    const bool may_build = !w.enabled || rebuild_deferred_ >= w.max_deferred_rebuild_steps ||
                           work_.left(tracking_forecast_) >= step;
    if (map_.refresh(in.t, normals, may_build)) ++counters_.map_rebuilds;
    work_.add(params_.work.rebuild_step * map_.steps_run());
    if (!may_build && map_.build_due(in.t)) {
      ++rebuild_deferred_;
      ++counters_.rebuild_steps_deferred;
    } else {
      rebuild_deferred_ = 0;
    }
    counters_.map_normals_computed += normals.computed;
    counters_.map_normals_refused += normals.refused;
    register_frame(in.t, in.body_T_lidar.matrix());
    last_frame_t_ = in.t;
    have_frame_ = true;
  }
  probe_(LocalizerStage::kFusion);
  fill_output(in.t);
  push_backfill();
  work_.start_period();  // map clouds until the next scan belong to the next period
  ++frame_;
  probe_(LocalizerStage::kIdle);
  return output_;
}

// The sweep's motion: the wheel speed, and the gyro's yaw rate when its samples reach the stamp
// (imu_intake.hpp, rate_ahead: the samples before the stamp carried along their trend to the
// sweep's middle, less the filter's bias, over its scale), else the latest CAN yaw rate, half a
// sweep and one sample's noise away from the rate the sweep turns at. Bias and scale are the
// filter's, slow states: the deskew->registration->filter loop TUNING.md warns of stays open at
// the rate.
VehicleMotion Localizer::deskew_motion(double t) {
  VehicleMotion motion = vehicle_;
  double rate = 0.0;
  const ImuParams& p = params_.filter.imu;
  if (motion.valid && filter_.initialized() &&
      imu_.rate_ahead(t, p.deskew_window, p.deskew_trend, 0.5 * params_.scan.frame_period, rate)) {
    motion.yaw_rate = filter_.corrected_gyro_rate(rate);
    ++counters_.imu_deskews;
  }
  return motion;
}

// KISS-ICP-style odometry on the deskewed scan, predicted from the vehicle signals over the
// actual frame gap (a dropped scan doubles it); its relative motion feeds the filter.
void Localizer::run_odometry(const EgoScanInput& in) {
  const Mat4d& body_T_lidar = in.body_T_lidar.matrix();
  Pose3d predicted = Pose3d::Identity();
  const bool have_previous = have_odometry_frame_;
  const double dt = in.t - last_odometry_t_;
  last_odometry_t_ = in.t;
  have_odometry_frame_ = true;
  const bool predict = scan_.has_vehicle_motion() && have_previous && dt < params_.odometry_prediction_max_gap;
  if (predict) {
    Vec6d xi = Vec6d::Zero();
    xi(0) = vehicle_.speed * dt;
    xi(5) = vehicle_.yaw_rate * dt;
    predicted.matrix() = se3_inverse(body_T_lidar) * se3_exp(xi) * body_T_lidar;
  }
  const OdometryResult r = odometry_.register_voxelized_frame(scan_.deskewed(), predict ? &predicted : nullptr);
  const std::uint64_t queries = static_cast<std::uint64_t>(r.iterations) * r.source_points;
  counters_.odometry_queries += queries;
  work_.add(params_.work.odometry_frame + static_cast<double>(queries) * params_.work.odometry_query);
  const bool ok = r.status == OdometryStatus::kOk || r.status == OdometryStatus::kFirstFrame;
  if (!ok) ++counters_.odometry_failures;
  if (r.query_capped) ++counters_.odometry_query_capped;
  if (r.fine_points_capped) ++counters_.odometry_frames_thinned;
  const Mat4d lidar_T_body = se3_inverse(body_T_lidar);
  output_.odometry_ok = ok;
  output_.odometry_pose = Pose3d(r.pose.matrix() * lidar_T_body);
  odom_T_body_ = output_.odometry_pose;
  if (r.status != OdometryStatus::kOk || !have_previous) return;
  filter_.on_odometry(in.t, dt, body_T_lidar * r.delta.matrix() * lidar_T_body);
  double grade = 0.0;
  if (attitude_.grade(odom_T_body_, grade)) filter_.on_road_grade(in.t, grade);
}

// Tracking from the filter's prediction while it is tight, else the start-up search; then the
// registration goes through the validity gate to the filter.
void Localizer::register_frame(double t, const Mat4d& body_T_lidar) {
  if (scan_.deskewed().empty()) {
    predict_only(t);
    return;
  }
  if (!map_.ready()) {
    filter_.count_failed_frame();
    return;
  }
  probe_(LocalizerStage::kDownsample);
  scan_.downsample_for_registration(body_T_lidar);
  RegistrationResult result;
  bool attempted_ok = true;
  bool withheld = false;
  if (filter_.can_track()) {
    output_.mode = LocalizationMode::kTracking;
    result = track(t, body_T_lidar, withheld);
  } else {
    output_.mode = LocalizationMode::kGlobalSearch;
    const StartupOutcome s = search(t, body_T_lidar);
    if (s.status == StartupStatus::kNotDue || s.status == StartupStatus::kSearching) {
      filter_.count_failed_frame();
      return;
    }
    result = s.registration;
    attempted_ok = s.status != StartupStatus::kRejected;
    withheld = tracking_.rival().contested();  // a start contested by a rival basin
    if (!attempted_ok) filter_.count_failed_frame();
  }
  probe_(LocalizerStage::kFusion);
  report_registration(result);
  if (attempted_ok && result.ok()) ++counters_.registrations_ok;
  fuse(t, result, attempted_ok, withheld);
}

// withheld: the track's rival basin is not decided (rival_basin.hpp).
RegistrationResult Localizer::track(double t, const Mat4d& body_T_lidar, bool& withheld) {
  probe_(LocalizerStage::kTracking);
  const TrackingFrame frame{attitude_.tilt(filter_.pose(), odom_T_body_), scan_.registration_scan(), scan_.tracking_scan(),
                            scan_.search_scan(),  scan_.stereo_cloud(),
                            map_.target(),        body_T_lidar.topRightCorner<3, 1>(),
                            icp_hints(),          probe_,
                            frame_,               odom_T_body_,
                            map_.busy(),          params_.work.enabled ? &work_ : nullptr};
  const double before = work_.spent();
  const TrackingOutcome o = tracking_.step(frame, search_scratch_, counters_);
  tracking_forecast_ = work_.spent() - before;  // the next period's rebuild decision expects as much
  output_.basin_audited = o.audit.audited;
  withheld = o.contested;
  if (o.audit.switch_basin) {
    lose_track();
    startup_.nominate(frame_, o.audit.candidate, odom_T_body_);  // a search must confirm it
  }
  if (o.stereo_attempted) {
    output_.stereo_attempted = true;
    output_.stereo_pose = Pose3d(o.stereo.transform);
    output_.stereo_fitness = o.stereo.fitness;
    output_.stereo_points = static_cast<std::uint32_t>(scan_.stereo_cloud().size());
    if (!o.contested && filter_.fuse_stereo(t, o.stereo, scan_.stereo_mean_sigma())) {
      output_.stereo_fused = true;
      ++counters_.stereo_fused;
    }
  }
  return o.registration;
}

StartupOutcome Localizer::search(double t, const Mat4d& body_T_lidar) {
  StartupFrame frame;
  frame.frame = frame_;
  frame.t = t;
  frame.scan = scan_.registration_scan();
  frame.search_scan = scan_.search_scan();
  frame.tracking_scan = scan_.tracking_scan();
  frame.map = map_.target();
  frame.gnss = gnss_;
  frame.course_known = course_.at(t, vehicle_.yaw_rate, frame.course);
  frame.sensor_in_body = body_T_lidar.topRightCorner<3, 1>();
  frame.odom_T_body = odom_T_body_;
  frame.filter_needs_start = filter_.needs_start();
  frame.icp_hints = icp_hints();
  frame.probe = probe_;
  if (params_.work.enabled) frame.work = &work_;
  StartupOutcome s = startup_.step(frame, search_scratch_, counters_);
  const StartupSearchReport& r = s.report;
  if (r.searched) {  // the hypotheses a new track may have to beat (rival_basin.hpp)
    tracking_.rival().note(r.best_pose, r.best_tight, frame_, odom_T_body_);
    tracking_.rival().note(r.runner_up_pose, r.runner_up_tight, frame_, odom_T_body_);
  }
  if (s.status == StartupStatus::kStartFilter) {
    const Pose3d start = filter_.start_pose(s.registration, s.confirmed_candidate);
    if (filter_.accepts_restart_at(start)) {
      filter_.start(t, start, vehicle_);
      tracking_.rival().on_start(start, frame_, odom_T_body_);
    } else {  // a look-alike outside the running filter's belief: reported, neither fused nor valid
      ++counters_.reacquisitions_refused;
      s.status = StartupStatus::kRejected;
      startup_.on_track_lost();  // the search starts over; the filter carries on
    }
  }
  if (r.searched) {
    output_.searched = true;
    output_.search_heading_used = r.heading_used;
    output_.search_best_tight = r.best_tight;
    output_.search_runner_up_tight = r.runner_up_tight;
    output_.search_best_conflicts = r.best_conflicts;
    output_.search_runner_up_conflicts = r.runner_up_conflicts;
    output_.search_best_pose = r.best_pose;
    output_.search_runner_up_pose = r.runner_up_pose;
  }
  return s;
}

void Localizer::report_registration(const RegistrationResult& result) {
  output_.registration_attempted = true;
  output_.registration_status = result.status;
  output_.registration_pose = Pose3d(result.transform);
  output_.fitness = result.fitness;
  output_.inlier_rmse = result.inlier_rmse;
}

// A sweep without points (a covered or silent LiDAR; the firmware's period closed without a scan)
// is no evidence against the track: nothing is registered or counted towards
// filter.max_failed_frames, the filter carries its prediction (its covariance grows) and the gate's
// window moves on. Whether the next sweep with points is tracked or searched is decided as for any
// frame (PoseFilter::can_track: the prediction's sigma against filter.tracking_max_sigma_xy).
void Localizer::predict_only(double t) {
  output_.no_scan_data = true;
  ++counters_.frames_without_scan_data;
  if (!map_.ready()) return;  // as any frame before the map: nothing to gate
  output_.mode = filter_.can_track() ? LocalizationMode::kTracking : LocalizationMode::kGlobalSearch;
  RegistrationResult none;
  none.status = RegistrationStatus::kNotEnoughPoints;
  fuse(t, none, true, false, true);
}

void Localizer::fuse(double t, const RegistrationResult& result, bool attempted_ok, bool withheld, bool no_data) {
  FrameRegistration reg;
  reg.frame = frame_;
  reg.t = t;
  reg.result = result;
  reg.attempted_ok = attempted_ok;
  reg.withheld = withheld;
  reg.no_data = no_data;
  reg.odom_T_body = odom_T_body_;
  reg.vehicle = vehicle_;
  const RegistrationFusion f = filter_.fuse(reg, counters_);
  // The tilt is well constrained by the ground even where the gate is still undecided.
  if (attempted_ok && !withheld && result.ok()) attitude_.on_registration(Pose3d(result.transform), odom_T_body_);
  output_.registration_fused = f.fused;
  output_.gate_decided = f.gate_decided;
  output_.gate_decided_frame = f.gate_decided_frame;
  output_.gate_decided_valid = f.gate_decided_valid;
}

// Tracking is lost (GNSS divergence monitor or basin audit): the filter and the search start over.
void Localizer::lose_track() {
  filter_.lose_track();
  attitude_.reset();
  startup_.on_track_lost();
  tracking_.on_track_lost();
  ++counters_.track_losses;
}

void Localizer::fill_output(double t) {
  OutputFrame frame;
  frame.t = t;
  frame.gnss = gnss_;
  frame.course_known = course_.at(t, vehicle_.yaw_rate, frame.course);
  frame.map_ready = map_.ready();
  frame.map_points = map_.points();
  frame.has_candidate = startup_.candidate_pose(frame_, odom_T_body_, frame.candidate);
  frame_output_.fill(frame, filter_, output_, counters_);
}

void Localizer::push_backfill() {
  BackfillSample sample;
  sample.frame = frame_;
  sample.odom_T_body = odom_T_body_.matrix();
  sample.world_T_body = output_.fused_pose.matrix();
  sample.anchored = output_.filter_initialized;
  sample.odometry_ok = output_.odometry_ok;
  output_.revised_frames = backfill_.push(sample);
}

}  // namespace v2xloc
