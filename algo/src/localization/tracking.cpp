#include "v2xloc/algo/localization/tracking.hpp"

#include "v2xloc/algo/registration/lazy_normals.hpp"

namespace v2xloc {

void TrackingRegistration::configure(const TrackingParams& params, const BasinAuditParams& audit,
                                     const PoseSearchParams& search) {
  params_ = params;
  audit_.configure(audit, search, params.icp);
  rival_.configure(params.rival, search, params.icp);
}

TrackingOutcome TrackingRegistration::step(const TrackingFrame& f, PoseSearchScratch& scratch, LocalizerCounters& counters) {
  TrackingOutcome out;
  ++counters.tracking_registrations;
  RegistrationResult& result = out.registration;
  result = icp(f.tracking_scan, f.map, f.predicted.matrix(), params_.icp, f.icp_hints);
  if (result.status == RegistrationStatus::kDidNotConverge) ++counters.tracking_work_capped;  // params_.icp.max_work
  const std::uint64_t queries = (static_cast<std::uint64_t>(result.iterations) + 1) * f.tracking_scan.size();
  counters.tracking_queries += queries;
  if (f.work != nullptr) {
    const PeriodWorkParams& w = f.work->params();
    const std::uint32_t normals = f.map.lazy_normals != nullptr ? f.map.lazy_normals->this_period().computed : 0u;
    f.work->add(static_cast<double>(queries) * w.tracking_query + normals * w.map_normal);
  }
  if (result.ok()) {
    // A contest withholds the track from the filter: its check comes first, the audit (insurance)
    // takes the period's rest.
    check_rival(f, out, counters);
    if (!out.audit.switch_basin) run_audit(f, out, scratch, counters);
    if (out.audit.switch_basin) result.status = RegistrationStatus::kDidNotConverge;
  }
  if (result.ok() && f.stereo_cloud.size() >= params_.stereo_min_points) {
    ++counters.stereo_registrations;
    out.stereo_attempted = true;
    out.stereo = icp(f.stereo_cloud, f.map, f.predicted.matrix(), params_.stereo_icp);
  }
  out.contested = rival_.contested();
  return out;
}

void TrackingRegistration::run_audit(const TrackingFrame& f, TrackingOutcome& out, PoseSearchScratch& scratch,
                                     LocalizerCounters& counters) {
  AuditFrame audit{Pose3d(out.registration.transform), f.scan, f.tracking_scan, f.search_scan, f.map, f.sensor_in_body,
                   f.icp_hints, f.probe, f.frame, f.odom_T_body, f.map_busy};
  if (f.work != nullptr) {
    const PeriodWorkParams& w = f.work->params();
    if (w.search_unit > 0.0) audit.work_cap = static_cast<std::uint64_t>(f.work->left() / w.search_unit);
    audit.room_to_start = f.work->left() >= w.audit_start;
    audit.decision.room = f.work->left();
    audit.decision.pass_price = w.tracking_query;
    audit.decision.evaluation_price = w.evaluation_point;
    audit.unit_price = w.search_unit;
  }
  out.audit = audit_.step(audit, scratch, counters);
  counters.tracking_queries += out.audit.queries;
  if (f.work != nullptr) {
    const PeriodWorkParams& w = f.work->params();
    f.work->add(static_cast<double>(out.audit.queries) * w.tracking_query +
                static_cast<double>(out.audit.evaluated) * w.evaluation_point);
  }
}

// A contested track: the rival is refined and judged on this frame's scan, within the period's
// remaining budget (priced as tracking queries and fitness evaluations).
void TrackingRegistration::check_rival(const TrackingFrame& f, TrackingOutcome& out, LocalizerCounters& counters) {
  if (!rival_.contested()) return;
  RivalFrame rf{Pose3d(out.registration.transform), f.scan, f.tracking_scan, f.map, f.icp_hints, f.frame, f.odom_T_body};
  if (f.work != nullptr) {
    rf.budget.room = f.work->left();
    rf.budget.pass_price = f.work->params().tracking_query;
    rf.budget.evaluation_price = f.work->params().evaluation_point;
  }
  const RivalOutcome r = rival_.check(rf);
  counters.tracking_queries += r.queries;
  if (r.deferred) ++counters.rival_checks_deferred;
  if (f.work != nullptr) {
    const PeriodWorkParams& w = f.work->params();
    f.work->add(static_cast<double>(r.queries) * w.tracking_query + static_cast<double>(r.evaluated) * w.evaluation_point);
  }
  if (r.switch_basin) {
    ++counters.basin_switches;
    out.audit.switch_basin = true;
    out.audit.candidate = r.candidate;
  }
}

}  // namespace v2xloc
