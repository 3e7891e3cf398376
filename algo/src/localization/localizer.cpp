// Localizer wiring (see localizer.hpp for the data flow). Each step is one private function:
// prepare_scan -> run_odometry -> refresh_map -> register_scan (tracking ICP or global search)
// -> fuse_gated (validity gate -> EKF) -> fill_output.
#include "v2xloc/algo/localization/localizer.hpp"

#include <cmath>

#include "v2xloc/algo/localization/deskew.hpp"
#include "v2xloc/algo/localization/ekf.hpp"
#include "v2xloc/algo/localization/scan_ingest.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/normals.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"
#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

Vec3f transform_point(const Mat4d& T, const Vec3f& p) {
  const Vec3d q = T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
  return q.cast<float>();
}

double horizontal_distance(const Mat4d& pose, const Vec3d& enu) {
  const double dx = pose(0, 3) - enu.x(), dy = pose(1, 3) - enu.y();
  return std::sqrt(dx * dx + dy * dy);
}

}  // namespace

void Localizer::configure(const LocalizerParams& params, const GeodeticOrigin& origin) {
  params_ = params;
  origin_ = origin;
  counters_ = {};
  output_ = {};
  backfill_.reset();
  ekf_ = Ekf(params.ekf);
  ekf_all_ = Ekf(params.ekf);
  fixed_lag_gate_ = FixedLagValidityGate(params.gate);
  causal_gate_ = CausalValidityGate(params.gate);
  stereo_gate_ = CausalValidityGate(params.gate);
  stereo_down_.clear();
  for (auto& p : pending_) p = {};
  frame_ = 0;
  gate_pushes_ = 0;
  failed_frames_ = 0;
  nis_rejections_ = 0;
  nis_rejections_ungated_ = 0;
  frames_since_global_ = params.global_retry_frames;  // allow a search at the first frame
  candidate_ = {};
  track_count_ = 0;
  odom_T_body_ = Mat4d::Identity();
  gnss_divergent_fixes_ = 0;
  frames_since_audit_ = 0;
  have_gnss_ = false;
  last_gnss_enu_ = Vec3d::Zero();
  last_gnss_sigma_ = 10.0;
  have_heading_ = false;
  heading_yaw_ = 0.0;
  heading_t_ = 0.0;
  have_frame_ = false;
  last_frame_t_ = 0.0;
  last_speed_ = 0.0;
  last_yaw_rate_ = 0.0;
  have_vehicle_ = false;
  have_vehicle_delta_ = false;
  odometry_.configure(params.odometry);
  odometry_.reset();
  map_.configure(params.map);
  map_targets_[0].points.clear();
  map_targets_[1].points.clear();
  map_active_ = 0;
  map_phase_ = MapBuildPhase::kIdle;
  map_tree_started_ = false;
  map_normals_done_ = 0;
  map_build_revision_ = 0;
  map_revision_ = ~0ull;
  map_built_t_ = -1e300;
  map_ready_ = false;
}

void Localizer::on_vehicle(const VehicleInput& in) {
  if (!std::isfinite(in.t) || !std::isfinite(in.wheel_speed) || !std::isfinite(in.yaw_rate)) return;
  last_speed_ = in.wheel_speed;
  last_yaw_rate_ = in.yaw_rate;
  have_vehicle_ = true;
  if (!params_.use_vehicle_signals || !ekf_.initialized()) return;
  ekf_.on_vehicle_signals(in.t, in.wheel_speed, in.yaw_rate);
  if (params_.shadow_ungated_filter) ekf_all_.on_vehicle_signals(in.t, in.wheel_speed, in.yaw_rate);
}

void Localizer::on_gnss(const GnssInput& in) {
  ++counters_.gnss_received;
  if (!in.valid || !std::isfinite(in.lat_deg) || !std::isfinite(in.lon_deg) ||
      !std::isfinite(in.alt_m) || !(in.h_acc > 0.0) || !(in.v_acc > 0.0) || !std::isfinite(in.t)) {
    ++counters_.gnss_invalid;
    return;
  }
  const Vec3d enu = geodetic_to_enu(origin_, GeodeticPoint{in.lat_deg, in.lon_deg, in.alt_m});
  have_gnss_ = true;
  last_gnss_enu_ = enu;
  last_gnss_sigma_ = in.h_acc;
  update_gnss_heading(in);
  if (ekf_.initialized()) {
    const EkfState s = ekf_.state();
    const double dx = s.pos_x - enu.x(), dy = s.pos_y - enu.y();
    const double limit = params_.gnss_divergence_sigmas * in.h_acc > params_.gnss_divergence_distance
                             ? params_.gnss_divergence_sigmas * in.h_acc
                             : params_.gnss_divergence_distance;
    gnss_divergent_fixes_ = dx * dx + dy * dy > limit * limit ? gnss_divergent_fixes_ + 1 : 0;
    if (params_.gnss_divergence_fixes > 0 && gnss_divergent_fixes_ >= params_.gnss_divergence_fixes) {
      lose_track();
      return;
    }
  }
  if (!params_.use_gnss || !ekf_.initialized()) return;
  ekf_.on_gnss(in.t, enu, in.h_acc, in.v_acc);
  if (params_.shadow_ungated_filter) ekf_all_.on_gnss(in.t, enu, in.h_acc, in.v_acc);
}

void Localizer::update_gnss_heading(const GnssInput& in) {
  if (!params_.use_gnss_heading || !in.velocity_valid || !std::isfinite(in.vel_east) ||
      !std::isfinite(in.vel_north) || !std::isfinite(in.speed_acc) || in.speed_acc < 0.0) {
    return;
  }
  const double speed = std::sqrt(in.vel_east * in.vel_east + in.vel_north * in.vel_north);
  // Forward motion only (reversing flips the course); the wheel speed must agree it is moving.
  if (speed < params_.heading_min_speed || !have_vehicle_ || last_speed_ < params_.heading_min_speed) return;
  if (det::atan2(in.speed_acc, speed) > params_.heading_max_sigma) return;
  have_heading_ = true;
  heading_yaw_ = det::atan2(in.vel_north, in.vel_east);  // ENU yaw: 0 = east, counter-clockwise
  heading_t_ = in.t;
  ++counters_.gnss_headings;
}

bool Localizer::gnss_heading_at(double t, double& yaw) const {
  if (!have_heading_ || !(std::abs(t - heading_t_) <= params_.heading_max_age)) return false;
  yaw = det::wrap_pi(heading_yaw_ + last_yaw_rate_ * (t - heading_t_));
  return true;
}

MapInsertResult Localizer::on_map_cloud(const MapCloudInput& in) {
  return map_.insert(in.source_id, in.t, in.world_T_sensor, in.points, !in.is_agent);
}

const LocalizerFrameOutput& Localizer::on_ego_scan(const EgoScanInput& in) {
  output_ = {};
  output_.frame = frame_;
  output_.t = in.t;
  ++counters_.frames;
  body_T_lidar_ = in.body_T_lidar;
  if (std::isfinite(in.t) && (!have_frame_ || in.t > last_frame_t_)) {
    probe_(LocalizerStage::kScanPrep);
    prepare_scan(in);
    stereo_down_.clear();
    if (params_.use_stereo && !in.stereo.disparity.empty()) prepare_stereo(in.stereo);
    probe_(LocalizerStage::kOdometry);
    run_odometry(in);
    probe_(LocalizerStage::kFusion);
    push_track_sample();
    if (ekf_.initialized()) {
      ekf_.predict_to(in.t);
      if (params_.shadow_ungated_filter) ekf_all_.predict_to(in.t);
    }
    probe_(LocalizerStage::kMapRefresh);
    refresh_map(in.t);
    register_scan(in.t);
    last_frame_t_ = in.t;
    have_frame_ = true;
  }
  probe_(LocalizerStage::kFusion);
  fill_output(in.t);
  BackfillSample sample;
  sample.frame = frame_;
  sample.odom_T_body = odom_T_body_;
  sample.world_T_body = output_.fused_pose;
  sample.anchored = output_.filter_initialized;
  sample.odometry_ok = output_.odometry_ok;
  output_.revised_frames = backfill_.push(sample);
  ++frame_;
  probe_(LocalizerStage::kIdle);
  return output_;
}

// The sweep read once (scan_ingest.hpp): finite returns within [min_range, max_range] merged
// per registration voxel in the LiDAR frame, then deskewed with the vehicle signals' motion.
void Localizer::prepare_scan(const EgoScanInput& in) {
  // Sensor motion over one frame from the latest wheel speed and yaw rate (constant velocity).
  // Raw vehicle signals, not the EKF's or the odometry's estimates: the deskewed scan feeds both,
  // and a deskew driven by what it feeds is a feedback loop (measured: at Sim 3's turn an
  // under-rotated odometry lowered the fused yaw rate, which under-deskewed the next scan...).
  have_vehicle_delta_ = have_vehicle_ && params_.use_vehicle_signals;
  if (have_vehicle_delta_) {
    Vec6d xi = Vec6d::Zero();
    xi(0) = last_speed_ * params_.frame_period;
    xi(5) = last_yaw_rate_ * params_.frame_period;
    vehicle_delta_lidar_ = se3_inverse(in.body_T_lidar) * se3_exp(xi) * in.body_T_lidar;
  }
  ScanIngestParams ip;
  ip.min_range = params_.min_range;
  ip.max_range = params_.max_range;
  ip.voxel = params_.registration_voxel;
  ip.frame_period = params_.frame_period;
  const bool deskew_now = params_.deskew && have_vehicle_delta_;
  const ScanIngestResult r = ingest_.run(in.points, in.point_times, deskew_now ? &vehicle_delta_lidar_ : nullptr, ip);
  counters_.scan_points_dropped += r.non_finite_dropped + r.range_dropped + r.capacity_dropped;
}

IcpTarget Localizer::map_target() const {
  const MapTarget& m = map_targets_[map_active_];
  return IcpTarget{m.points.span(), std::span<const Vec3f>(m.normals, m.points.size()), &m.tree.tree};
}

void Localizer::run_odometry(const EgoScanInput& in) {
  const std::span<const Vec3f> scan = ingest_.points();
  // Prediction from the vehicle signals over the actual frame gap (a dropped scan doubles it).
  Mat4d predicted = Mat4d::Identity();
  const bool predict = have_vehicle_delta_ && have_frame_ && in.t - last_frame_t_ < params_.odometry_prediction_max_gap;
  if (predict) {
    const double dt = in.t - last_frame_t_;
    Vec6d xi = Vec6d::Zero();
    xi(0) = last_speed_ * dt;
    xi(5) = last_yaw_rate_ * dt;
    predicted = se3_inverse(in.body_T_lidar) * se3_exp(xi) * in.body_T_lidar;
  }
  const OdometryResult r = odometry_.register_voxelized_frame(scan, predict ? &predicted : nullptr);
  const bool ok = r.status == OdometryStatus::kOk || r.status == OdometryStatus::kFirstFrame;
  if (!ok) ++counters_.odometry_failures;
  const Mat4d lidar_T_body = se3_inverse(in.body_T_lidar);
  output_.odometry_ok = ok;
  output_.odometry_pose = r.pose * lidar_T_body;
  odom_T_body_ = output_.odometry_pose;
  if (r.status != OdometryStatus::kOk || !have_frame_ || !params_.use_odometry ||
      !ekf_.initialized()) {
    return;
  }
  const Mat4d body_delta = in.body_T_lidar * r.delta * lidar_T_body;
  const double dt = in.t - last_frame_t_;
  ekf_.on_odometry(in.t, dt, body_delta);
  if (params_.shadow_ungated_filter) ekf_all_.on_odometry(in.t, dt, body_delta);
}

// Rebuilds the registration target (merged points, k-d tree, normals) when the map changed,
// at most every map_refresh_period: infrastructure clouds arrive several times per second and
// the static scene hardly changes between them.
void Localizer::refresh_map(double t) {
  map_.expire(t);
  // One build step per period while a map is in use; the first one is built at once.
  const std::uint32_t steps = map_ready_ ? 1u : kMapBuildSteps;
  for (std::uint32_t s = 0; s < steps; ++s) {
    if (!map_build_step(t)) break;
  }
}

bool Localizer::map_build_step(double t) {
  MapTarget& next = map_targets_[1 - map_active_];
  switch (map_phase_) {
    case MapBuildPhase::kIdle:
      if (map_.revision() == map_revision_) return false;
      if (map_ready_ && t - map_built_t_ < params_.map_refresh_period) return false;
      map_.extract(next.points);
      map_build_revision_ = map_.revision();
      map_built_t_ = t;
      map_phase_ = MapBuildPhase::kTree;
      map_tree_started_ = false;
      map_tree_result_ = {};
      return map_ready_ ? false : true;  // extraction is this period's map work
    case MapBuildPhase::kTree: {
      if (!map_tree_started_) {
        next.tree.begin_build(next.points.span());
        map_tree_started_ = true;
      }
      const std::size_t quota = map_ready_ && params_.map_tree_work_per_period > 0 ? params_.map_tree_work_per_period
                                                                                  : ~std::size_t{0};
      if (!next.tree.tree.build_step(quota, map_tree_result_)) return false;  // more next period
      map_tree_started_ = false;
      map_normals_done_ = 0;
      map_phase_ = MapBuildPhase::kNormals;
      return true;
    }
    case MapBuildPhase::kNormals: {
      NormalParams np;
      np.radius = params_.map_normal_radius;
      np.orient_to_viewpoint = false;  // point-to-plane residuals do not care about the sign
      const std::size_t n = next.points.size();
      const std::size_t slice = map_ready_ && params_.map_normals_per_period > 0 ? params_.map_normals_per_period : n;
      estimate_normals_range(next.tree.tree, np, map_normals_done_, slice,
                             std::span<Vec3f>(next.normals, config::kMaxMapPoints));
      map_normals_done_ += slice;
      if (map_normals_done_ < n) return false;  // more next period
      map_active_ = 1 - map_active_;
      map_revision_ = map_build_revision_;
      map_phase_ = MapBuildPhase::kIdle;
      map_ready_ = next.points.size() >= params_.map_min_points;
      ++counters_.map_rebuilds;
      return false;
    }
  }
  return false;
}

void Localizer::register_scan(double t) {
  ++frames_since_global_;
  if (!map_ready_) {
    ++failed_frames_;
    return;
  }
  // Source: the ingested scan (already one point per registration voxel) in the body frame.
  probe_(LocalizerStage::kDownsample);
  scan_down_.clear();
  for (const Vec3f& p : ingest_.points()) scan_down_.push_back(transform_point(body_T_lidar_, p));
  // The tracking ICP's points: an even subsample of at most tracking_points (the ICP's cost
  // is one nearest-neighbour query per point and iteration).
  tracking_scan_.clear();
  {
    const std::size_t n = scan_down_.size();
    const std::size_t want = params_.tracking_points > 0 ? params_.tracking_points : n;
    const std::size_t stride = n > want ? (n + want - 1) / want : 1;
    for (std::size_t i = 0; i < n; i += stride) tracking_scan_.push_back(scan_down_[i]);
  }
  search_scan_.clear();
  {
    const std::size_t want = params_.search_points < config::kMaxSearchPoints ? params_.search_points
                                                                               : config::kMaxSearchPoints;
    const std::size_t n = scan_down_.size();
    const std::size_t stride = want > 0 && n > want ? (n + want - 1) / want : 1;
    for (std::size_t i = 0; i < n; i += stride) search_scan_.push_back(scan_down_[i]);
  }

  const IcpTarget target = map_target();
  const double sigma_xy = ekf_.initialized()
      ? std::sqrt(0.5 * (ekf_.covariance()(ekf_index::kPosX, ekf_index::kPosX) +
                         ekf_.covariance()(ekf_index::kPosY, ekf_index::kPosY)))
      : 1e9;
  const bool tracking = ekf_.initialized() && sigma_xy <= params_.tracking_max_sigma_xy &&
                        failed_frames_ <= params_.max_failed_frames;
  RegistrationResult result;
  if (tracking) {
    output_.mode = LocalizationMode::kTracking;
    probe_(LocalizerStage::kTracking);
    ++counters_.tracking_registrations;
    result = icp(tracking_scan_.span(), target, ekf_.state().pose(), params_.icp,
                 std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
    if (result.ok() && result.inlier_rmse > params_.max_inlier_rmse) {
      result.status = RegistrationStatus::kDidNotConverge;  // counted as a failed frame
    }
    if (result.ok() && params_.audit_period_frames > 0 && ++frames_since_audit_ >= params_.audit_period_frames) {
      frames_since_audit_ = 0;
      probe_(LocalizerStage::kAudit);
      if (!audit_basin(result)) result.status = RegistrationStatus::kDidNotConverge;
      probe_(LocalizerStage::kTracking);
    }
    if (result.ok() && stereo_down_.size() >= params_.stereo_min_points) register_stereo(t);
  } else {
    output_.mode = LocalizationMode::kGlobalSearch;
    if (!have_gnss_ || frames_since_global_ < params_.global_retry_frames) {
      ++failed_frames_;
      return;
    }
    frames_since_global_ = 0;
    probe_(LocalizerStage::kGlobalSearch);
    const bool found = global_search(t, result);
    probe_(LocalizerStage::kFusion);
    if (!found) {
      output_.registration_attempted = true;
      output_.registration_status = result.status;
      output_.registration_pose = result.transform;
      output_.fitness = result.fitness;
      output_.inlier_rmse = result.inlier_rmse;
      ++failed_frames_;
      fuse_gated(t, result, false);
      return;
    }
  }
  probe_(LocalizerStage::kFusion);
  output_.registration_attempted = true;
  output_.registration_status = result.status;
  output_.registration_pose = result.transform;
  output_.fitness = result.fitness;
  output_.inlier_rmse = result.inlier_rmse;
  if (result.ok()) ++counters_.registrations_ok;
  fuse_gated(t, result, true);
}

// FPFH + RANSAC against the map around the GNSS fix, ICP refinement, then two checks the
// symmetric intersection needs: the solution must lie inside the GNSS uncertainty region and
// explain enough of the scan.
bool Localizer::global_search(double t, RegistrationResult& result) {
  ++counters_.global_searches;
  const IcpTarget target = map_target();
  double region = params_.global_gnss_gate_sigmas *
                  (last_gnss_sigma_ * params_.ekf.gates.gnss_sigma_inflation + 1.0);
  if (region < params_.global_min_region) region = params_.global_min_region;
  // (1) Exhaustive, GNSS-seeded search over position and heading.
  PoseSearchParams sp = params_.search;
  sp.radius = region < sp.radius ? region : sp.radius;
  sp.sensor_in_body = body_T_lidar_.topRightCorner<3, 1>();
  double course = 0.0;
  const bool heading_known = gnss_heading_at(t, course);
  if (heading_known) {
    sp.use_yaw_prior = true;
    sp.yaw_prior = course;
    sp.yaw_prior_tolerance = params_.heading_search_tolerance;
    ++counters_.heading_searches;
  }
  const PoseSearchResult searched =
      search_pose(search_scan_.span(), target, last_gnss_enu_, sp,
                  std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
  output_.searched = true;
  output_.search_heading_used = heading_known;
  output_.search_best_tight = searched.best_tight_fitness;
  output_.search_runner_up_tight = searched.runner_up_tight_fitness;
  output_.search_best_conflicts = searched.best_conflicts;
  output_.search_runner_up_conflicts = searched.runner_up_conflicts;
  output_.search_best_pose = searched.best.transform;
  output_.search_runner_up_pose = searched.runner_up.transform;
  RegistrationResult best = searched.best;
  const bool distinct = searched.best_tight_fitness > 0.0 &&
                        searched.runner_up_tight_fitness <
                            params_.global_max_ambiguity * searched.best_tight_fitness;
  if (!distinct) {
    best.status = RegistrationStatus::kDidNotConverge;
    double d_best = 0.0, d_other = 0.0;
    if (searched.best.ok() && searched.runner_up.ok() && track_gnss_distance(searched.best.transform, d_best) &&
        track_gnss_distance(searched.runner_up.transform, d_other)) {
      const double lo = d_best < d_other ? d_best : d_other, hi = d_best < d_other ? d_other : d_best;
      if (lo < params_.track_distance_ratio * hi && hi - lo > params_.track_distance_margin) {
        best = d_best < d_other ? searched.best : searched.runner_up;
        ++counters_.ambiguities_resolved;
      }
    }
  }
  // (2) The paper's FPFH + RANSAC against the map around the fix, with the same prior.
  if (params_.use_fpfh_ransac) {
    map_crop_.clear();
    const double r2 = params_.global_map_radius * params_.global_map_radius;
    for (const Vec3f& p : map_targets_[map_active_].points) {
      const double dx = p.x() - last_gnss_enu_.x(), dy = p.y() - last_gnss_enu_.y();
      if (dx * dx + dy * dy <= r2) map_crop_.push_back(p);
    }
    RegisterCloudsParams gp = params_.global;
    gp.ransac.prior.center = Vec3d(last_gnss_enu_.x(), last_gnss_enu_.y(), searched.ground_z);
    gp.ransac.prior.max_horizontal = region;
    gp.ransac.prior.max_vertical = params_.global_max_vertical;
    const RegisterCloudsResult coarse = register_clouds(scan_down_.span(), map_crop_.span(), gp,
                                                        Mat4d::Identity(), global_workspace_);
    if (coarse.registration.ok()) {
      // Only confirms the exhaustive search (same basin); alone it is not trusted in a canyon.
      // On the search's points, so that its fitness compares with the search's candidates.
      const RegistrationResult r = icp(search_scan_.span(), target, coarse.registration.transform, sp.icp,
                                       std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
      if (r.ok() && best.ok() && r.fitness > best.fitness &&
          horizontal_distance(r.transform, best.transform.topRightCorner<3, 1>()) < sp.distinct_distance) {
        best = r;
      }
    }
  }
  if (!best.ok()) {
    result = best;
    return false;
  }
  // Final refinement with the tracking ICP, then the acceptance checks.
  result = icp(scan_down_.span(), target, best.transform, params_.icp,
               std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
  if (!result.ok()) return false;
  double track_distance = 0.0;
  const bool track_known = params_.use_gnss && track_gnss_distance(result.transform, track_distance);
  const bool heading_agrees =
      heading_known &&
      std::abs(det::wrap_pi(yaw_of(result.transform.topLeftCorner<3, 3>()) - course)) <= params_.heading_search_tolerance;
  if (result.fitness < params_.global_min_fitness || result.inlier_rmse > params_.max_inlier_rmse ||
      (heading_known && !heading_agrees) ||
      (params_.use_gnss && horizontal_distance(result.transform, last_gnss_enu_) > region) ||
      (track_known && track_distance > params_.track_max_distance)) {
    result.status = RegistrationStatus::kDidNotConverge;
    return false;
  }
  ++counters_.global_accepted;
  if (!ekf_.initialized() || failed_frames_ > params_.max_failed_frames) {
    // An unconfirmed candidate is reported (Reg. column) but neither gated nor fused.
    // Output before confirmation when it is unlikely to be the mirror: the course says so, the
    // GNSS track does, or the search over every heading left no other pose standing (the ray
    // check removed the rest). Still flagged not localized until a second search confirms it.
    const bool sole = !heading_known && sp.max_conflicts > 0.0 && searched.best.ok() &&
                      searched.runner_up_tight_fitness <= 0.0;
    if (!confirm_global(result.transform, track_known || heading_agrees || sole)) return false;
    initialize_filters(t, result.transform);
  }
  return true;
}

bool Localizer::confirm_global(const Mat4d& pose, bool output) {
  if (params_.global_confirm_window == 0) return true;
  if (candidate_.valid && frame_ - candidate_.frame <= params_.global_confirm_window) {
    const Mat4d predicted = candidate_.pose * se3_inverse(candidate_.odom) * odom_T_body_;
    const double dyaw = det::wrap_pi(yaw_of(pose.topLeftCorner<3, 3>()) - yaw_of(predicted.topLeftCorner<3, 3>()));
    if (horizontal_distance(pose, predicted.topRightCorner<3, 1>()) <= params_.global_confirm_distance &&
        std::abs(dyaw) <= params_.global_confirm_yaw) {
      candidate_.valid = false;
      ++counters_.global_confirmed;
      return true;
    }
    ++counters_.global_inconsistent;
  }
  candidate_.valid = true;
  candidate_.frame = frame_;
  candidate_.pose = pose;
  candidate_.odom = odom_T_body_;
  candidate_.output = output;
  return false;
}

void Localizer::push_track_sample() {
  if (!output_.odometry_ok) {
    track_count_ = 0;  // the odometry track is broken: start a new one
    return;
  }
  TrackSample& s = track_[track_count_ % kTrackFrames];
  s.odom_x = odom_T_body_(0, 3);
  s.odom_y = odom_T_body_(1, 3);
  s.gnss = have_gnss_;
  s.gnss_x = last_gnss_enu_.x();
  s.gnss_y = last_gnss_enu_.y();
  ++track_count_;
}

bool Localizer::track_gnss_distance(const Mat4d& pose, double& mean_distance) const {
  const std::uint32_t limit = params_.track_frames < kTrackFrames ? params_.track_frames
                                                                  : static_cast<std::uint32_t>(kTrackFrames);
  const std::uint32_t n = track_count_ < limit ? track_count_ : limit;
  const Mat4d world_T_odom = pose * se3_inverse(odom_T_body_);
  double sum = 0.0;
  std::uint32_t m = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const TrackSample& s = track_[(track_count_ - 1 - i) % kTrackFrames];
    if (!s.gnss) continue;
    const double x = world_T_odom(0, 0) * s.odom_x + world_T_odom(0, 1) * s.odom_y + world_T_odom(0, 3);
    const double y = world_T_odom(1, 0) * s.odom_x + world_T_odom(1, 1) * s.odom_y + world_T_odom(1, 3);
    sum += std::sqrt((x - s.gnss_x) * (x - s.gnss_x) + (y - s.gnss_y) * (y - s.gnss_y));
    ++m;
  }
  if (m < params_.track_min_fixes) return false;
  mean_distance = sum / m;
  return true;
}

// Disparity -> points in the body frame with depth sigmas, the noisy far ones dropped, then
// downsampled like the LiDAR scan.
void Localizer::prepare_stereo(const StereoInput& stereo) {
  StereoParams sp = params_.stereo;
  if (stereo.disparity_sigma > 0.0) sp.disparity_sigma = stereo.disparity_sigma;
  const StereoCloudResult r =
      stereo_to_cloud(stereo.disparity, stereo.scale, stereo.width, stereo.height, stereo.calibration, sp, std::span<Vec3f>(stereo_points_, config::kMaxStereoPoints),
                      std::span<float>(stereo_sigma_, config::kMaxStereoPoints));
  if (r.status == StereoStatus::kInvalidInput || r.points_out == 0) return;
  double sum = 0.0;
  for (std::uint32_t i = 0; i < r.points_out; ++i) sum += stereo_sigma_[i];
  stereo_mean_sigma_ = sum / r.points_out;
  voxel_.run(std::span<const Vec3f>(stereo_points_, r.points_out), params_.stereo_voxel, stereo_down_);
}

// The stereo cloud registered to the map from the same prediction, gated causally, fused at the
// frame's time stamp with a covariance no tighter than its depth noise allows.
void Localizer::register_stereo(double t) {
  ++counters_.stereo_registrations;
  const RegistrationResult r = icp(stereo_down_.span(), map_target(), ekf_.state().pose(), params_.stereo_icp);
  output_.stereo_attempted = true;
  output_.stereo_pose = r.transform;
  output_.stereo_fitness = r.fitness;
  output_.stereo_points = static_cast<std::uint32_t>(stereo_down_.size());
  const GateDecision d = stereo_gate_.push(GateSample{r.fitness, r.inlier_rmse, r.ok()});
  if (!d.valid || !r.ok()) return;
  const double sigma = r.inlier_rmse > stereo_mean_sigma_ ? r.inlier_rmse : stereo_mean_sigma_;
  RegistrationCovarianceParams cp = params_.registration_covariance;
  cp.scale *= params_.stereo_covariance_scale;
  const Eigen::Matrix<double, 4, 4> cov = registration_covariance(r.information, sigma, r.transform, cp);
  if (params_.shadow_ungated_filter) ekf_all_.on_registration(t, r.transform, cov);
  if (ekf_.on_registration(t, r.transform, cov) == EkfFuseStatus::kFused) {
    output_.stereo_fused = true;
    ++counters_.stereo_fused;
  }
}

bool Localizer::audit_basin(const RegistrationResult& tracked) {
  ++counters_.basin_audits;
  output_.basin_audited = true;
  const IcpTarget target = map_target();
  PoseSearchParams sp = params_.search;
  sp.radius = params_.audit_radius;
  sp.sensor_in_body = body_T_lidar_.topRightCorner<3, 1>();
  const PoseSearchResult s =
      search_pose(search_scan_.span(), target, tracked.transform.topRightCorner<3, 1>(), sp,
                  std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
  if (!s.best.ok()) return true;
  const Mat4d d = se3_inverse(tracked.transform) * s.best.transform;
  const bool distinct = std::sqrt(d(0, 3) * d(0, 3) + d(1, 3) * d(1, 3)) >= sp.distinct_distance ||
                        std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))) >= sp.distinct_yaw;
  if (!distinct) return true;
  const double tracked_tight = evaluate_registration(search_scan_.span(), target, tracked.transform,
                                                     sp.select_distance).fitness;
  if (!(s.best_tight_fitness > params_.audit_switch_ratio * tracked_tight)) return true;
  // The subset only nominates a basin. The switch is decided on the full scan: the candidate is
  // refined there with the tracking ICP (as an accepted pose would be) and must still be another
  // basin and beat the tracked pose's full-scan tight fitness by audit_full_switch_ratio.
  const RegistrationResult full = icp(scan_down_.span(), target, s.best.transform, params_.icp,
                                      std::span<std::uint32_t>(icp_hints_, config::kMaxDownsampledPoints));
  const double tracked_full = evaluate_registration(scan_down_.span(), target, tracked.transform,
                                                    sp.select_distance).fitness;
  const double cand_full = full.ok() ? evaluate_registration(scan_down_.span(), target, full.transform,
                                                             sp.select_distance).fitness : 0.0;
  const Mat4d df = se3_inverse(tracked.transform) * full.transform;
  const bool still_distinct = std::sqrt(df(0, 3) * df(0, 3) + df(1, 3) * df(1, 3)) >= sp.distinct_distance ||
                              std::abs(det::wrap_pi(yaw_of(df.topLeftCorner<3, 3>()))) >= sp.distinct_yaw;
  if (!full.ok() || !still_distinct || !(cand_full > params_.audit_full_switch_ratio * tracked_full)) return true;
  ++counters_.basin_switches;
  lose_track();
  candidate_.valid = true;  // a global search must confirm it before the filter restarts
  candidate_.output = true;  // found next to a tracked pose: a better estimate than GNSS
  candidate_.frame = frame_;
  candidate_.pose = full.transform;
  candidate_.odom = odom_T_body_;
  return false;
}

// Tracking is lost (GNSS divergence monitor or basin audit): both filters start over globally.
void Localizer::lose_track() {
  ekf_.reset();
  ekf_all_.reset();
  candidate_.valid = false;
  failed_frames_ = 0;
  nis_rejections_ = 0;
  nis_rejections_ungated_ = 0;
  gnss_divergent_fixes_ = 0;
  frames_since_global_ = params_.global_retry_frames;
  ++counters_.track_losses;
}

void Localizer::restart_filter(Ekf& ekf, double t, const Mat4d& pose) {
  EkfState s;
  s.pos_x = pose(0, 3);
  s.pos_y = pose(1, 3);
  s.pos_z = pose(2, 3);
  s.yaw = yaw_of(pose.topLeftCorner<3, 3>());
  s.speed = last_speed_;
  s.yaw_rate = last_yaw_rate_;
  EkfCovariance P = EkfCovariance::Zero();
  const double* sigmas = params_.restart_sigmas;
  for (int i = 0; i < kEkfStateSize; ++i) P(i, i) = sigmas[i] * sigmas[i];
  ekf.initialize(t, s, P);
  ekf.predict_to(t);
}

void Localizer::initialize_filters(double t, const Mat4d& pose) {
  restart_filter(ekf_, t, pose);
  if (params_.shadow_ungated_filter) restart_filter(ekf_all_, t, pose);
  failed_frames_ = 0;
}

// Validity gate -> EKF. The shadow filter takes every ok registration; the main one only those
// the gate accepts (fixed-lag: w/2 frames later, fused at the frame's own time stamp through the
// EKF's history).
void Localizer::fuse_gated(double t, const RegistrationResult& result, bool attempted_ok) {
  PendingRegistration reg;
  reg.frame = frame_;
  reg.t = t;
  reg.pose = result.transform;
  reg.odom = odom_T_body_;
  reg.ok = attempted_ok && result.ok();
  if (reg.ok) {
    reg.covariance = registration_covariance(result.information, result.inlier_rmse, result.transform,
                                             params_.registration_covariance);
    bool fused_all = false;
    if (params_.shadow_ungated_filter) fuse_registration(ekf_all_, reg, t, fused_all);
  }
  const GateSample sample{result.fitness, result.inlier_rmse, reg.ok};
  bool fused = false;
  switch (params_.gate_mode) {
    case GateMode::kOff:
      if (reg.ok) fuse_registration(ekf_, reg, t, fused);
      break;
    case GateMode::kCausal: {
      const GateDecision d = causal_gate_.push(sample);
      output_.gate_decided = d.available;
      output_.gate_decided_frame = static_cast<std::uint32_t>(d.frame);
      output_.gate_decided_valid = d.valid;
      if (d.valid && reg.ok) fuse_registration(ekf_, reg, t, fused);
      break;
    }
    case GateMode::kFixedLag: {
      // The gate counts its own pushes (frames without a registration attempt are not pushed);
      // the ring is indexed by that count and remembers the localizer frame.
      reg.gate_index = gate_pushes_++;
      pending_[reg.gate_index % kPendingCapacity] = reg;
      const GateDecision d = fixed_lag_gate_.push(sample);
      if (d.available) {
        const PendingRegistration& late = pending_[d.frame % kPendingCapacity];
        if (late.gate_index == d.frame) {
          output_.gate_decided = true;
          output_.gate_decided_frame = late.frame;
          output_.gate_decided_valid = d.valid;
          if (d.valid && late.ok) fuse_registration(ekf_, late, t, fused);
        }
      }
      break;
    }
  }
  if (fused) {
    failed_frames_ = 0;
  } else if (!reg.ok) {
    ++failed_frames_;
  }
  if (!reg.ok || (params_.gate_mode != GateMode::kFixedLag && !fused)) {
    ++counters_.registrations_gate_rejected;
  }
  output_.registration_fused = fused;
}

// A registration the validity gate accepted but the filter's NIS gate keeps rejecting means the
// filter, not the registration, is wrong (it drifted on odometry while over-confident): after
// reset_after_rejections such frames in a row the filter restarts at the registration.
void Localizer::fuse_registration(Ekf& ekf, const PendingRegistration& reg, double now, bool& fused) {
  if (!ekf.initialized()) return;
  const EkfFuseStatus status = ekf.on_registration(reg.t, reg.pose, reg.covariance);
  fused = status == EkfFuseStatus::kFused;
  std::uint32_t& rejections = &ekf == &ekf_ ? nis_rejections_ : nis_rejections_ungated_;
  if (fused) {
    rejections = 0;
    if (&ekf == &ekf_) ++counters_.registrations_fused;
    return;
  }
  if (status != EkfFuseStatus::kRejectedGate) return;
  if (++rejections < params_.reset_after_rejections) return;
  rejections = 0;
  ++counters_.filter_resets;
  // A fixed-lag registration is w/2 frames old: restart at the current frame with its pose
  // carried forward by the odometry (restarting at its own time stamp would leave the output
  // behind by the distance driven since, ~3 m at 6 m/s).
  restart_filter(ekf, now, reg.pose * se3_inverse(reg.odom) * odom_T_body_);
  fused = true;
}

void Localizer::fill_output(double t) {
  output_.t = t;
  output_.filter_initialized = ekf_.initialized();
  if (!ekf_.initialized()) {
    // Best estimate without a filter: an unconfirmed global candidate carried by the odometry,
    // else the GNSS fix, set on the map's road surface (the vehicle is on the road; a canyon's
    // GNSS altitude is off by more than its horizontal position) and turned to the course over
    // ground when there is one. Either way not localized, with the GNSS sigma.
    Mat4d pose = Mat4d::Identity();
    pose.topRightCorner<3, 1>() = last_gnss_enu_;
    double road_z = 0.0;
    if (have_gnss_ && map_ready_ &&
        road_height_near(map_targets_[map_active_].points.span(), last_gnss_enu_, params_.global_map_radius, road_z,
                    params_.road_height_min_points)) {
      pose(2, 3) = road_z;
      ++counters_.road_height_outputs;
    }
    double course = 0.0;
    if (gnss_heading_at(t, course)) pose.topLeftCorner<3, 3>() = rot_z(course);
    if (candidate_.valid && candidate_.output && frame_ - candidate_.frame <= params_.global_confirm_window) {
      pose = candidate_.pose * se3_inverse(candidate_.odom) * odom_T_body_;
    }
    output_.fused_pose = pose;
    output_.fused_pose_ungated = pose;
    output_.sigma_x = output_.sigma_y = have_gnss_ ? last_gnss_sigma_ : 1e3;
    output_.sigma_z = output_.sigma_x;
    output_.sigma_yaw = det::kPi;
    output_.localized = false;
    return;
  }
  output_.fused_pose = ekf_.state().pose();
  output_.fused_pose_ungated = params_.shadow_ungated_filter ? ekf_all_.state().pose() : output_.fused_pose;
  const EkfCovariance& P = ekf_.covariance();
  output_.sigma_x = std::sqrt(P(ekf_index::kPosX, ekf_index::kPosX));
  output_.sigma_y = std::sqrt(P(ekf_index::kPosY, ekf_index::kPosY));
  output_.sigma_z = std::sqrt(P(ekf_index::kPosZ, ekf_index::kPosZ));
  output_.sigma_yaw = std::sqrt(P(ekf_index::kYaw, ekf_index::kYaw));
  const double sigma_xy = std::sqrt(0.5 * (P(0, 0) + P(1, 1)));
  output_.localized = sigma_xy <= params_.localized_sigma_xy;
}

}  // namespace v2xloc
