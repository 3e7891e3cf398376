// The basin audit: every period_frames tracked frames a local exhaustive pose search around the
// tracked pose asks whether tracking sits in an aliased basin (a street repeats itself along its
// length). The search runs as a job spread over the following tracked frames, work_per_period
// work units each (pose_search.hpp), on the scan and tracked pose of the frame it started at; its
// answer is carried to the current frame by the odometry. The search's subsample only nominates
// another basin; the switch is decided on the current full scan after the tracking ICP. Owns its
// period count and the job; one entry point per tracked frame (step) with everything it reads in
// an AuditFrame; its settings are BasinAuditParams (localizer_params.hpp).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/basin_decision.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

struct AuditFrame {
  Pose3d tracked = Pose3d::Identity();   // this frame's tracking registration (ok)
  std::span<const Vec3f> scan{};         // registration scan (body frame, downsampled)
  std::span<const Vec3f> tracking_scan{};  // its subsample the tracking ICP registers
  std::span<const Vec3f> search_scan{};  // its subsample for the pose search
  IcpTarget map{};
  Vec3d sensor_in_body = Vec3d::Zero();
  std::span<std::uint32_t> icp_hints{};  // ICP scratch, >= scan.size()
  StageProbe probe{};                    // marks kAudit while it runs, then kTracking
  std::uint32_t frame = 0;               // localizer frame index
  Pose3d odom_T_body = Pose3d::Identity();  // this frame's odometry pose
  bool map_busy = false;  // map clouds were fused this period: the audit waits for a quieter one
  // [work units] at most this much this period (the period budget's rest; 0: it waits)
  std::uint64_t work_cap = ~std::uint64_t{0};
  bool room_to_start = true;  // the period budget has room for an audit's set-up
  // The period's rest before the audit's slice and the prices of a full-scan decision (room
  // infinite: decided at once); unit_price prices the slice's work units out of that room.
  BasinDecisionBudget decision{};
  double unit_price = 0.0;
};

struct AuditOutcome {
  bool audited = false;                   // the audit ran this frame
  bool switch_basin = false;              // tracking is in a wrong basin ...
  Pose3d candidate = Pose3d::Identity();  // ... and this is the better one (world_T_body)
  std::uint64_t queries = 0;    // the full-scan decision's ICP queries, for the period budget
  std::uint64_t evaluated = 0;  // and its fitness evaluations' points
};

class BasinAudit {
 public:
  // search: the start-up search's pose search (lattice, scoring, ICPs; radius and candidates are
  // the audit's); icp: the tracking ICP, which decides a switch on the full scan.
  void configure(const BasinAuditParams& params, const PoseSearchParams& search, const IcpParams& icp);
  // scratch: the pose search's (pose_search.hpp), shared with the caller's other searches.
  AuditOutcome step(const AuditFrame& frame, PoseSearchScratch& scratch, LocalizerCounters& counters);
  // Tracking was lost: a running search no longer describes the track, and the next track is
  // audited early (see first_audit_due()).
  void cancel() {
    running_ = false;
    pending_ = false;
    frames_since_audit_ = first_audit_due();
    first_of_track_ = true;
  }

 private:
  void start(const AuditFrame& f);
  // A new track was accepted by a search, possibly on a map still missing sources (shares lost
  // at start-up): its first audit is due after first_frames tracked frames, not a whole
  // period_frames.
  std::uint32_t first_audit_due() const {
    return params_.period_frames > params_.first_frames ? params_.period_frames - params_.first_frames : 0u;
  }
  AuditOutcome finish(const AuditFrame& f, double room, LocalizerCounters& counters);
  // The nominated basin against the tracked pose on this frame's full scan (basin_decision.hpp),
  // within room: a switch when it still differs and beats it by full_switch_ratio; a decision the
  // room cannot hold stays pending for the next tracked frame.
  AuditOutcome decide(const AuditFrame& f, double room, LocalizerCounters& counters);

  BasinAuditParams params_{};
  PoseSearchParams search_{};  // as configured; search_params_ is the running job's
  IcpParams icp_{};
  std::uint32_t frames_since_audit_ = 0;
  bool first_of_track_ = true;  // the next audit is the track's first (it takes the period's room)
  PoseSearch job_{};
  // The audit's own hypothesis scoring bitmap, as the start-up search's (TUNING.md, "Candidates
  // and grid").
  ProximityGrid grid_{};
  PoseSearchParams search_params_{};
  bool running_ = false;
  std::uint32_t started_frame_ = 0;
  Mat4d tracked_at_start_ = Mat4d::Identity();  // world_T_body the search was started around
  Mat4d odom_at_start_ = Mat4d::Identity();     // odom_T_body at that frame
  bool pending_ = false;                        // a nomination waits for its full-scan decision
  std::uint32_t pending_frame_ = 0;             // the frame it was nominated at
  PendingBasinDecision nomination_{};
};

}  // namespace v2xloc
