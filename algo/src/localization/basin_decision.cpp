#include "v2xloc/algo/localization/basin_decision.hpp"

#include <cmath>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {
namespace {

// The stride of an even subsample the room left after the ICP holds, both poses evaluated on it:
// 1 the whole scan; s > 1 every s-th point, at least min_points of them (0: no floor); 0 when not
// even that fits. A forced decision takes the finest stride the room holds, at worst the floor's.
std::uint32_t evaluation_stride(std::size_t n, double left, const BasinDecisionBudget& b) {
  if (n == 0) return 1;
  const double need = 2.0 * b.evaluation_price * static_cast<double>(n);
  if (!(need > left)) return 1;
  const std::size_t floor_points = b.min_points == 0 ? 1 : (b.min_points < n ? b.min_points : n);
  const std::size_t coarsest = n / floor_points;  // >= 1
  const double per_pose = std::floor(left / (2.0 * b.evaluation_price));  // whole points per pose
  const double stride = per_pose >= 1.0 ? std::ceil(static_cast<double>(n) / per_pose) : static_cast<double>(n) + 1.0;
  if (stride <= static_cast<double>(coarsest)) return static_cast<std::uint32_t>(stride);
  return b.forced ? static_cast<std::uint32_t>(coarsest) : 0u;
}

}  // namespace

bool distinct_basin(const Mat4d& a, const Mat4d& b, const PoseSearchParams& sp) {
  const Mat4d d = se3_inverse(a) * b;
  return std::sqrt(d(0, 3) * d(0, 3) + d(1, 3) * d(1, 3)) >= sp.distinct_distance ||
         std::abs(det::wrap_pi(yaw_of(d.topLeftCorner<3, 3>()))) >= sp.distinct_yaw;
}

BasinDecision decide_basin(const BasinDecisionInput& in, const IcpParams& icp_params, const PoseSearchParams& search,
                           const BasinDecisionBudget& budget) {
  BasinDecision d;
  d.refined = in.candidate;
  const double room = budget.room > 0.0 ? budget.room : 0.0;
  double icp_cost = 0.0;
  if (!in.refined) {
    const std::span<const Vec3f> scan = in.tracking_scan.empty() ? in.scan : in.tracking_scan;
    // The passes the room prices; no bound when it holds the ICP's most, when forced or unpriced.
    // Fewer than two cannot converge (the criteria compare two passes of one run): it waits.
    const double pass_cost = budget.pass_price * static_cast<double>(scan.size());
    const std::uint32_t most = (icp_params.criteria.max_iterations < config::kIcpMaxIterations
                                    ? icp_params.criteria.max_iterations
                                    : config::kIcpMaxIterations) + 1u;
    std::uint32_t passes = ~std::uint32_t{0};
    if (!budget.forced && pass_cost > 0.0 && room < pass_cost * most) {
      passes = static_cast<std::uint32_t>(room / pass_cost);  // < most: no overflow
      if (passes < 2) return d;                               // waiting, nothing ran
    }
    IcpRun run;
    icp_begin(run, scan, in.map, in.candidate, icp_params, in.icp_hints);
    const std::uint64_t work = icp_params.max_work > 0 ? icp_params.max_work : ~std::uint64_t{0};
    const bool finished = icp_continue(run, scan, in.map, icp_params, passes, in.icp_hints, work);
    d.queries = static_cast<std::uint64_t>(run.passes) * scan.size();
    icp_cost = static_cast<double>(run.passes) * pass_cost;
    const bool out_of_work = !finished && run.in_pass;  // as icp(): ends like its iteration cap
    d.refined = finished ? run.result.transform : run.transform;
    if (out_of_work || (finished && !run.result.ok()) || !d.refined.allFinite()) {
      d.state = BasinDecisionState::kLost;
      return d;
    }
    if (!finished) return d;  // the room ended the ICP: waiting, it goes on from d.refined
  }
  d.icp_finished = true;
  // A candidate that slid into the tracked basin contests nothing.
  if (!distinct_basin(in.tracked, d.refined, search)) {
    d.state = BasinDecisionState::kLost;
    return d;
  }
  const std::uint32_t stride = evaluation_stride(in.scan.size(), room - icp_cost, budget);
  if (stride == 0) return d;  // waiting, refined: only the evaluations are left
  d.stride = stride;
  d.evaluated = 2 * ((in.scan.size() + stride - 1) / stride);
  const double select = search.select_distance;
  d.tracked_fitness = evaluate_registration(in.scan, in.map, in.tracked, select, stride).fitness;
  d.candidate_fitness = evaluate_registration(in.scan, in.map, d.refined, select, stride).fitness;
  d.state = BasinDecisionState::kDecided;
  return d;
}

BasinDecision PendingBasinDecision::step(BasinDecisionInput in, const Mat4d& odom_now, const IcpParams& icp,
                                         const PoseSearchParams& search, BasinDecisionBudget budget,
                                         const BasinDecisionParams& params) {
  in.candidate = carried_by_odometry(pose_, odom_, odom_now);
  in.refined = refined_;
  budget.min_points = params.min_points;
  budget.forced = waited_ >= params.max_deferred_frames;
  const BasinDecision d = decide_basin(in, icp, search, budget);
  if (d.state == BasinDecisionState::kLost) return d;
  if (d.queries > 0) {  // refined this frame: carried on from here
    pose_ = d.refined;
    odom_ = odom_now;
  }
  const bool waiting = d.state == BasinDecisionState::kWaiting;
  refined_ = waiting && d.icp_finished;
  waited_ = waiting ? waited_ + 1 : 0;
  return d;
}

}  // namespace v2xloc
