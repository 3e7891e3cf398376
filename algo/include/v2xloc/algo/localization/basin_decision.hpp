// Tracked basin or another one, decided on this frame's scan within the period's remaining budget.
// The rival basin's check and the basin audit's nomination both end here: the other basin's pose
// is refined with the tracking ICP (on the tracking subsample), then both poses' tight fitness is
// evaluated on the registration scan, and the caller compares the two with its own ratios. On a
// real 17.9k-point scan the whole decision costs ~50 M instructions, more than a tracked period of
// a real drive has left, so it is priced as it runs: the ICP takes the passes the room holds (an
// unfinished ICP hands back its latest pose, to be carried by the odometry and resumed next frame;
// fewer than two passes wait, as one cannot converge) and the two evaluations take the whole scan
// when the room holds them, else an even subsample of at least min_points (a finished ICP whose
// evaluations wait is not run again). A forced decision (the caller's bound on waiting) runs the
// whole ICP and the finest subsample the room holds, at worst min_points.
#pragma once

#include <cstdint>
#include <limits>
#include <span>

#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

struct BasinDecisionBudget {
  double room = std::numeric_limits<double>::infinity();  // [instructions] the period's rest
  double pass_price = 0.0;        // [instructions] per ICP point and nearest-neighbour pass
  double evaluation_price = 0.0;  // [instructions] per point of a fitness evaluation
  std::uint32_t min_points = 1000;  // [points] the fewest a subsampled evaluation judges each pose on (0: no floor)
  bool forced = false;              // decide whatever the room
};

struct BasinDecisionInput {
  Mat4d tracked = Mat4d::Identity();    // this frame's tracking registration (world_T_body)
  Mat4d candidate = Mat4d::Identity();  // the other basin's pose, carried to this frame
  std::span<const Vec3f> scan{};           // registration scan: both poses are judged on it
  std::span<const Vec3f> tracking_scan{};  // its subsample the ICP registers (empty: the scan)
  IcpTarget map{};
  std::span<std::uint32_t> icp_hints{};  // ICP scratch, >= the registered scan's size
  bool refined = false;  // the candidate is an earlier frame's finished ICP: only the evaluations are left
};

enum class BasinDecisionState : std::uint8_t {
  kDecided,  // both fitnesses evaluated
  kWaiting,  // the room ended the ICP or cannot hold the evaluations: `refined` carries on
  kLost,     // the ICP failed, or the candidate slid into the tracked basin: nothing to decide
};

struct BasinDecision {
  BasinDecisionState state = BasinDecisionState::kWaiting;
  Mat4d refined = Mat4d::Identity();  // the candidate after this frame's ICP passes
  bool icp_finished = false;          // refined is a finished ICP's (waiting: only the evaluations left)
  double tracked_fitness = 0.0;       // tight fitness on the (subsampled) scan (kDecided)
  double candidate_fitness = 0.0;
  std::uint64_t queries = 0;    // ICP nearest-neighbour queries (points x passes)
  std::uint64_t evaluated = 0;  // points of the two evaluations
  std::uint32_t stride = 0;     // evaluation subsample stride (1: the whole scan; 0: none ran)
  double priced(const BasinDecisionBudget& b) const {
    return static_cast<double>(queries) * b.pass_price + static_cast<double>(evaluated) * b.evaluation_price;
  }
};

// Another basin: a and b (world_T_body) apart by the search's distinct distance or heading.
bool distinct_basin(const Mat4d& a, const Mat4d& b, const PoseSearchParams& search);

// icp: the tracking ICP; search: distinct basins and the tight select distance.
BasinDecision decide_basin(const BasinDecisionInput& in, const IcpParams& icp, const PoseSearchParams& search,
                           const BasinDecisionBudget& budget);

// Another basin's pose waiting for its decision over tracked frames: carried by the odometry,
// refined as far as each frame's room allows, decided regardless after max_deferred_frames waits.
// The rival basin's contest and the basin audit's nomination each hold one.
class PendingBasinDecision {
 public:
  // pose (world_T_body) at the frame whose odometry pose is odom.
  void start(const Mat4d& pose, const Mat4d& odom) {
    pose_ = pose;
    odom_ = odom;
    refined_ = false;
    waited_ = 0;
  }
  // This frame's decision (decide_basin): in without its candidate, which comes from the carried
  // pose; odom_now this frame's odometry pose; budget's min_points and forced from params.
  BasinDecision step(BasinDecisionInput in, const Mat4d& odom_now, const IcpParams& icp, const PoseSearchParams& search,
                     BasinDecisionBudget budget, const BasinDecisionParams& params);

 private:
  Mat4d pose_ = Mat4d::Identity();  // world_T_body at odom_
  Mat4d odom_ = Mat4d::Identity();
  bool refined_ = false;            // pose_ is a finished ICP's: only the evaluations wait
  std::uint32_t waited_ = 0;        // frames in a row without a decision
};

}  // namespace v2xloc
