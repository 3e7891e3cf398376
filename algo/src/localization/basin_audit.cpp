#include "v2xloc/algo/localization/basin_audit.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {
namespace {

// Another basin: apart by the search's distinct distance or heading.
bool distinct_basin(const Mat4d& a, const Mat4d& b, const PoseSearchParams& sp) {
  const Mat4d d = se3_inverse(a) * b;
  return std::sqrt(d(0, 3) * d(0, 3) + d(1, 3) * d(1, 3)) >= sp.distinct_distance ||
         std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))) >= sp.distinct_yaw;
}

}  // namespace

void BasinAudit::configure(const LocalizerParams& params) {
  params_ = params;
  frames_since_audit_ = 0;
}

AuditOutcome BasinAudit::step(const AuditFrame& f, LocalizerCounters& counters) {
  if (params_.audit_period_frames == 0 || ++frames_since_audit_ < params_.audit_period_frames) return {};
  frames_since_audit_ = 0;
  f.probe(LocalizerStage::kAudit);
  const AuditOutcome out = audit(f, counters);
  f.probe(LocalizerStage::kTracking);
  return out;
}

AuditOutcome BasinAudit::audit(const AuditFrame& f, LocalizerCounters& counters) const {
  AuditOutcome out;
  ++counters.basin_audits;
  out.audited = true;
  const Mat4d& tracked = f.tracked.matrix();
  PoseSearchParams sp = params_.search;
  sp.radius = params_.audit_radius;
  sp.sensor_in_body = f.sensor_in_body;
  const PoseSearchResult s = search_pose(f.search_scan, f.map, tracked.topRightCorner<3, 1>(), sp, f.icp_hints);
  if (!s.best.ok() || !distinct_basin(tracked, s.best.transform, sp)) return out;
  const double tracked_tight = evaluate_registration(f.search_scan, f.map, tracked, sp.select_distance).fitness;
  if (!(s.best_tight_fitness > params_.audit_switch_ratio * tracked_tight)) return out;
  Mat4d refined = Mat4d::Identity();
  if (!wins_on_full_scan(f, s.best.transform, refined)) return out;
  ++counters.basin_switches;
  out.switch_basin = true;
  out.candidate = Pose3d(refined);
  return out;
}

// The candidate is refined with the tracking ICP (as an accepted pose would be) and must still
// be another basin and beat the tracked pose's full-scan tight fitness.
bool BasinAudit::wins_on_full_scan(const AuditFrame& f, const Mat4d& nominated, Mat4d& refined) const {
  const Mat4d& tracked = f.tracked.matrix();
  const double select = params_.search.select_distance;
  const RegistrationResult full = icp(f.scan, f.map, nominated, params_.icp, f.icp_hints);
  const double tracked_full = evaluate_registration(f.scan, f.map, tracked, select).fitness;
  const double cand_full = full.ok() ? evaluate_registration(f.scan, f.map, full.transform, select).fitness : 0.0;
  if (!full.ok() || !distinct_basin(tracked, full.transform, params_.search) ||
      !(cand_full > params_.audit_full_switch_ratio * tracked_full)) {
    return false;
  }
  refined = full.transform;
  return true;
}

}  // namespace v2xloc
