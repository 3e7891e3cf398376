#include "v2xloc/algo/localization/rival_basin.hpp"

#include <cmath>

#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/localization/basin_audit.hpp"

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
  deferred_ = 0;
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
  for (std::size_t i = 0; i < note_count_; ++i) {
    const Note& n = notes_[i];
    if (frame - n.frame > params_.max_age_frames) continue;
    const Mat4d carried = carried_by_odometry(n.pose, n.odom, odom_T_body.matrix());
    if (n.tight > any) any = n.tight;
    if (!distinct_basin(pose.matrix(), carried, search_)) {
      if (n.tight > same) same = n.tight;
    } else if (n.tight > rival_tight) {
      rival_tight = n.tight;
      rival_ = carried;
    }
  }
  note_count_ = 0;
  const double reference = same > 0.0 ? same : any;
  if (!(rival_tight > 0.0) || rival_tight < params_.contest_ratio * reference) return;
  rival_odom_ = odom_T_body.matrix();
  contested_ = true;
  deferred_ = 0;
}

RivalOutcome RivalBasin::check(const RivalFrame& f) {
  RivalOutcome out;
  if (!contested_) return out;
  out.checked = true;
  const bool forced = deferred_ >= params_.max_deferred_frames;
  const Mat4d carried = carried_by_odometry(rival_, rival_odom_, f.odom_T_body.matrix());
  const std::span<const Vec3f> scan = f.tracking_scan.empty() ? f.scan : f.tracking_scan;
  // The ICP's passes the room prices (no bound when it holds the ICP's most, when forced or unpriced).
  const double pass_cost = f.pass_price * static_cast<double>(scan.size());
  std::uint32_t passes = ~std::uint32_t{0};
  if (!forced && pass_cost > 0.0 && f.room < pass_cost * (icp_.criteria.max_iterations + 1.0)) {
    passes = static_cast<std::uint32_t>(f.room / pass_cost);
    if (passes == 0) return defer(out);
  }
  IcpRun run;
  icp_begin(run, scan, f.map, carried, icp_, f.icp_hints);
  const std::uint64_t work = icp_.max_work > 0 ? icp_.max_work : ~std::uint64_t{0};
  const bool finished = icp_continue(run, scan, f.map, icp_, passes, f.icp_hints, work);
  out.queries = static_cast<std::uint64_t>(run.passes) * scan.size();
  const bool out_of_work = !finished && run.in_pass;  // as icp(): ends like its iteration cap
  const Mat4d& refined = finished ? run.result.transform : run.transform;
  // A rival the scan no longer holds, or one that slid into the tracked basin, contests nothing.
  if (out_of_work || (finished && !run.result.ok()) || !refined.allFinite() ||
      !distinct_basin(f.tracked.matrix(), refined, search_)) {
    contested_ = false;
    return out;
  }
  rival_ = refined;
  rival_odom_ = f.odom_T_body.matrix();
  if (!finished) return defer(out);  // the room ended the ICP: it goes on next frame
  // Both poses on the whole registration scan, or on the even subsample the room holds.
  const std::uint32_t stride = evaluation_stride(f, static_cast<double>(run.passes) * pass_cost, forced);
  if (stride == 0) return defer(out);
  deferred_ = 0;
  out.stride = stride;
  out.evaluated = 2 * ((f.scan.size() + stride - 1) / stride);
  const double select = search_.select_distance;
  const double tracked_full = evaluate_registration(f.scan, f.map, f.tracked.matrix(), select, stride).fitness;
  const double rival_full = evaluate_registration(f.scan, f.map, refined, select, stride).fitness;
  if (rival_full > params_.switch_ratio * tracked_full) {
    contested_ = false;
    out.switch_basin = true;
    out.candidate = Pose3d(refined);
  } else if (tracked_full > params_.resolve_ratio * rival_full) {
    contested_ = false;
  }
  return out;
}

RivalOutcome& RivalBasin::defer(RivalOutcome& out) {
  ++deferred_;
  out.deferred = true;
  return out;
}

// 1: the whole scan fits the room left after the ICP; s > 1: every s-th point, at least
// min_decision_points of them; 0: not even that fits (a forced decision takes the minimum).
std::uint32_t RivalBasin::evaluation_stride(const RivalFrame& f, double icp_cost, bool forced) const {
  const std::size_t n = f.scan.size();
  const double need = 2.0 * f.evaluation_price * static_cast<double>(n);
  const double left = f.room - icp_cost;
  if (!(need > left)) return 1;
  const std::size_t floor_points = params_.min_decision_points < n ? params_.min_decision_points : n;
  const std::size_t min_stride = floor_points > 0 ? n / floor_points : 1;
  if (forced) return min_stride > 0 ? static_cast<std::uint32_t>(min_stride) : 1u;
  if (!(left > 0.0)) return 0;
  const double fit = left / (2.0 * f.evaluation_price);  // points per pose the room holds
  const double stride = std::ceil(static_cast<double>(n) / fit);
  if (stride > static_cast<double>(min_stride)) return 0;
  return static_cast<std::uint32_t>(stride);
}

}  // namespace v2xloc
