#include "v2xloc/algo/localization/rival_basin.hpp"

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

void RivalBasin::configure(const RivalBasinParams& params, const PoseSearchParams& search, const IcpParams& icp) {
  params_ = params;
  search_ = search;
  icp_ = icp;
  reset();
}

void RivalBasin::reset() {
  note_count_ = 0;
  contested_ = false;
}

void RivalBasin::note(const Pose3d& pose, double tight, std::uint32_t frame, const Pose3d& odom_T_body) {
  if (!(tight > 0.0) || !pose.matrix().allFinite()) return;
  std::size_t slot = note_count_;
  if (note_count_ == kNotes) {  // full: the weakest note makes room for a stronger one
    slot = 0;
    for (std::size_t i = 1; i < kNotes; ++i) {
      if (notes_[i].tight < notes_[slot].tight) slot = i;
    }
    if (!(tight > notes_[slot].tight)) return;
  } else {
    ++note_count_;
  }
  notes_[slot] = Note{pose.matrix(), odom_T_body.matrix(), tight, frame};
}

void RivalBasin::on_start(const Pose3d& pose, std::uint32_t frame, const Pose3d& odom_T_body) {
  contested_ = false;
  double same = 0.0, any = 0.0, rival_tight = 0.0;
  Mat4d rival = Mat4d::Identity();
  for (std::size_t i = 0; i < note_count_; ++i) {
    const Note& n = notes_[i];
    if (frame - n.frame > params_.max_age_frames) continue;
    const Mat4d carried = carried_by_odometry(n.pose, n.odom, odom_T_body.matrix());
    if (n.tight > any) any = n.tight;
    if (!distinct_basin(pose.matrix(), carried, search_)) {
      if (n.tight > same) same = n.tight;
    } else if (n.tight > rival_tight) {
      rival_tight = n.tight;
      rival = carried;
    }
  }
  note_count_ = 0;
  const double reference = same > 0.0 ? same : any;
  if (!(rival_tight > 0.0) || rival_tight < params_.contest_ratio * reference) return;
  pending_.start(rival, odom_T_body.matrix());
  contested_ = true;
}

RivalOutcome RivalBasin::check(const RivalFrame& f) {
  RivalOutcome out;
  if (!contested_) return out;
  out.checked = true;
  const BasinDecisionInput in{f.tracked.matrix(), Mat4d::Identity(), f.scan, f.tracking_scan, f.map, f.icp_hints};
  const BasinDecision d = pending_.step(in, f.odom_T_body.matrix(), icp_, search_, f.budget, params_.decision);
  out.queries = d.queries;
  out.evaluated = d.evaluated;
  out.stride = d.stride;
  // A rival the scan no longer holds, or one that slid into the tracked basin, contests nothing.
  if (d.state == BasinDecisionState::kLost) {
    contested_ = false;
    return out;
  }
  if (d.state == BasinDecisionState::kWaiting) {
    out.deferred = true;
    return out;
  }
  contested_ = false;
  if (d.candidate_fitness > params_.switch_ratio * d.tracked_fitness) {
    out.switch_basin = true;
    out.candidate = Pose3d(d.refined);
  } else if (!(d.tracked_fitness > params_.resolve_ratio * d.candidate_fitness)) {
    contested_ = true;  // neither clearly: the next tracked frame judges again
  }
  return out;
}

}  // namespace v2xloc
