#include "v2xloc/algo/localization/basin_audit.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

void BasinAudit::configure(const BasinAuditParams& params, const PoseSearchParams& search, const IcpParams& icp) {
  params_ = params;
  search_ = search;
  icp_ = icp;
  job_.set_proximity_grid(&grid_);
  running_ = false;
  pending_ = false;
  frames_since_audit_ = first_audit_due();
  first_of_track_ = true;
}

AuditOutcome BasinAudit::step(const AuditFrame& f, PoseSearchScratch& scratch, LocalizerCounters& counters) {
  // A nomination whose decision the room did not hold; dropped when it outlived its track (frames
  // without tracking in between), as a running search is.
  if (pending_ && f.frame - pending_frame_ > params_.max_frames) pending_ = false;
  if (pending_) {
    f.probe(LocalizerStage::kAudit);
    const AuditOutcome out = decide(f, f.decision.room, counters);
    f.probe(LocalizerStage::kTracking);
    return out;
  }
  // A search that outlived its track (frames without tracking in between) is dropped.
  if (running_ && f.frame - started_frame_ > params_.max_frames) running_ = false;
  // Periods that fused map clouds have spent part of their spare work: the audit is insurance, it
  // takes a smaller quota there or waits (the frames it pauses count towards max_frames).
  // A new track's first audit takes all the room the period has left: until it ends, an alias
  // accepted on an incomplete map is the output (~25 frames on the fixed quotas).
  const std::uint32_t fixed = f.map_busy ? params_.work_per_busy_period : params_.work_per_period;
  const std::uint64_t quota = first_of_track_ ? f.work_cap : (fixed < f.work_cap ? fixed : f.work_cap);
  const bool paused = (!first_of_track_ && f.map_busy && fixed == 0) || f.work_cap == 0;
  // This period's work units, the set-up's included (start() counts the job's work from 0).
  const std::uint64_t slice_from = running_ ? job_.work() : 0;
  if (!running_) {
    if (params_.period_frames == 0 || ++frames_since_audit_ < params_.period_frames) return {};
    if (paused || !f.room_to_start) return {};  // due: starts in the next period with room
    frames_since_audit_ = 0;
    f.probe(LocalizerStage::kAudit);
    start(f);
  } else {
    if (paused) {
      ++counters.audit_periods_starved;
      return {};
    }
    f.probe(LocalizerStage::kAudit);
  }
  const std::uint64_t budget = quota > 0 ? quota : ~std::uint64_t{0};
  AuditOutcome out;
  const std::uint64_t before = job_.work();
  const bool done = job_.step(f.map, scratch, budget);
  counters.audit_work += job_.work() - before;
  if (done) {
    running_ = false;
    first_of_track_ = false;
    out = finish(f, f.decision.room - static_cast<double>(job_.work() - slice_from) * f.unit_price, counters);
  }
  f.probe(LocalizerStage::kTracking);
  return out;
}

void BasinAudit::start(const AuditFrame& f) {
  search_params_ = search_;
  search_params_.radius = params_.radius;
  search_params_.sensor_in_body = f.sensor_in_body;
  search_params_.refine_candidates = params_.refine_candidates;
  tracked_at_start_ = f.tracked.matrix();
  odom_at_start_ = f.odom_T_body.matrix();
  started_frame_ = f.frame;
  job_.start(f.search_scan, f.map, tracked_at_start_.topRightCorner<3, 1>(), search_params_);
  running_ = true;
}

// The search's verdict, in the frame it started at; a nominated basin is carried to this frame
// by the odometry and decided on this frame's full scan.
AuditOutcome BasinAudit::finish(const AuditFrame& f, double room, LocalizerCounters& counters) {
  AuditOutcome out;
  ++counters.basin_audits;
  out.audited = true;
  const PoseSearchResult& s = job_.result();
  const PoseSearchParams& sp = search_params_;
  if (!s.best.ok() || !distinct_basin(tracked_at_start_, s.best.transform, sp)) return out;
  // The search covered the disc around the tracked pose; an ICP that walked out of it (a scan the
  // map barely explains, a degenerate direction) is no nomination.
  const double dx = s.best.transform(0, 3) - tracked_at_start_(0, 3), dy = s.best.transform(1, 3) - tracked_at_start_(1, 3);
  const double reach = sp.radius + sp.step;
  if (dx * dx + dy * dy > reach * reach) return out;
  const double tracked_tight = evaluate_registration(job_.scan(), f.map, tracked_at_start_, sp.select_distance).fitness;
  if (!(s.best_tight_fitness > params_.switch_ratio * tracked_tight)) return out;
  pending_ = true;
  pending_frame_ = f.frame;
  nomination_.start(s.best.transform, odom_at_start_);
  AuditOutcome decided = decide(f, room, counters);
  decided.audited = true;
  return decided;
}

// The candidate is refined with the tracking ICP on the tracking subsample (as an accepted pose
// and every tracked frame are: on the whole scan the ICP's work cap ended it unconverged, so no
// audit could switch) and must still be another basin and beat the tracked pose's full-scan tight
// fitness.
AuditOutcome BasinAudit::decide(const AuditFrame& f, double room, LocalizerCounters& counters) {
  AuditOutcome out;
  const BasinDecisionInput in{f.tracked.matrix(), Mat4d::Identity(), f.scan, f.tracking_scan, f.map, f.icp_hints};
  BasinDecisionBudget budget = f.decision;
  budget.room = room;
  const BasinDecision d = nomination_.step(in, f.odom_T_body.matrix(), icp_, search_, budget, params_.decision);
  out.queries = d.queries;
  out.evaluated = d.evaluated;
  if (d.state == BasinDecisionState::kWaiting) {
    ++counters.audit_decisions_deferred;
    return out;
  }
  pending_ = false;
  if (d.state == BasinDecisionState::kLost || !(d.candidate_fitness > params_.full_switch_ratio * d.tracked_fitness)) {
    return out;
  }
  ++counters.basin_switches;
  out.switch_basin = true;
  out.candidate = Pose3d(d.refined);
  return out;
}

}  // namespace v2xloc
