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
  std::uint64_t audit_cap = ~std::uint64_t{0};
  bool room_to_start = true;
  if (f.work != nullptr) {
    const PeriodWorkParams& w = f.work->params();
    const std::uint32_t normals = f.map.lazy_normals != nullptr ? f.map.lazy_normals->this_period().computed : 0u;
    f.work->add(static_cast<double>(queries) * w.tracking_query + normals * w.map_normal);
    if (w.search_unit > 0.0) audit_cap = static_cast<std::uint64_t>(f.work->left() / w.search_unit);
    room_to_start = f.work->left() >= w.audit_start;
  }
  if (result.ok()) {
    AuditFrame audit{Pose3d(result.transform), f.scan, f.tracking_scan, f.search_scan, f.map, f.sensor_in_body, f.icp_hints,
                     f.probe, f.frame, f.odom_T_body, f.map_busy};
    audit.work_cap = audit_cap;
    audit.room_to_start = room_to_start;
    out.audit = audit_.step(audit, scratch, counters);
    if (!out.audit.switch_basin) check_rival(f, out, counters);
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

// A contested track: the rival is refined and judged on this frame's scan (priced as tracking).
void TrackingRegistration::check_rival(const TrackingFrame& f, TrackingOutcome& out, LocalizerCounters& counters) {
  if (!rival_.contested()) return;
  const RivalFrame rf{Pose3d(out.registration.transform), f.scan, f.tracking_scan, f.map, f.icp_hints, f.frame, f.odom_T_body};
  const RivalOutcome r = rival_.check(rf);
  counters.tracking_queries += r.queries;
  if (f.work != nullptr) f.work->add(static_cast<double>(r.queries) * f.work->params().tracking_query);
  if (r.switch_basin) {
    ++counters.basin_switches;
    out.audit.switch_basin = true;
    out.audit.candidate = r.candidate;
  }
}

}  // namespace v2xloc
