#include "v2xloc/algo/localization/tracking.hpp"

#include "v2xloc/algo/registration/lazy_normals.hpp"

namespace v2xloc {
namespace {

// The period's rest and the prices of a basin decision (basin_decision.hpp); unpriced without a budget.
BasinDecisionBudget decision_budget(const PeriodWork* work) {
  BasinDecisionBudget b;
  if (work == nullptr) return b;
  b.room = work->left();
  b.pass_price = work->params().tracking_query;
  b.evaluation_price = work->params().evaluation_point;
  return b;
}

// A decision's work: its ICP queries count as tracking's, and both go into the period's estimate.
void charge_decision(PeriodWork* work, std::uint64_t queries, std::uint64_t evaluated, LocalizerCounters& counters) {
  counters.tracking_queries += queries;
  if (work == nullptr) return;
  const PeriodWorkParams& w = work->params();
  work->add(static_cast<double>(queries) * w.tracking_query + static_cast<double>(evaluated) * w.evaluation_point);
}

}  // namespace

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
    audit.unit_price = w.search_unit;
  }
  audit.decision = decision_budget(f.work);
  out.audit = audit_.step(audit, scratch, counters);
  charge_decision(f.work, out.audit.queries, out.audit.evaluated, counters);
}

// A contested track: the rival is refined and judged on this frame's scan, within the period's
// remaining budget (priced as tracking queries and fitness evaluations).
void TrackingRegistration::check_rival(const TrackingFrame& f, TrackingOutcome& out, LocalizerCounters& counters) {
  if (!rival_.contested()) return;
  const RivalFrame rf{Pose3d(out.registration.transform), f.scan, f.tracking_scan, f.map, f.icp_hints, f.frame,
                      f.odom_T_body, decision_budget(f.work)};
  const RivalOutcome r = rival_.check(rf);
  if (r.deferred) ++counters.rival_checks_deferred;
  charge_decision(f.work, r.queries, r.evaluated, counters);
  if (r.switch_basin) {
    ++counters.basin_switches;
    out.audit.switch_basin = true;
    out.audit.candidate = r.candidate;
  }
}

}  // namespace v2xloc
