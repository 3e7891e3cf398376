#include "v2xloc/algo/localization/tracking.hpp"

namespace v2xloc {

void TrackingRegistration::configure(const LocalizerParams& params) {
  params_ = params;
  audit_.configure(params);
}

TrackingOutcome TrackingRegistration::step(const TrackingFrame& f, LocalizerCounters& counters) {
  TrackingOutcome out;
  ++counters.tracking_registrations;
  RegistrationResult& result = out.registration;
  result = icp(f.tracking_scan, f.map, f.predicted.matrix(), params_.icp, f.icp_hints);
  if (result.ok() && result.inlier_rmse > params_.max_inlier_rmse) {
    result.status = RegistrationStatus::kDidNotConverge;  // counted as a failed frame
  }
  if (result.ok()) {
    const AuditFrame audit{Pose3d(result.transform), f.scan, f.search_scan, f.map, f.sensor_in_body, f.icp_hints,
                           f.probe, f.frame, f.odom_T_body, f.map_busy};
    out.audit = audit_.step(audit, counters);
    if (out.audit.switch_basin) result.status = RegistrationStatus::kDidNotConverge;
  }
  if (result.ok() && f.stereo_cloud.size() >= params_.stereo_min_points) {
    ++counters.stereo_registrations;
    out.stereo_attempted = true;
    out.stereo = icp(f.stereo_cloud, f.map, f.predicted.matrix(), params_.stereo_icp);
  }
  return out;
}

}  // namespace v2xloc
