// The start-up (and lost-track) search: where on the map is the vehicle, with only the GNSS fix
// to go by. A GNSS-seeded exhaustive pose search (pose_search.hpp), refined by the tracking ICP
// and checked against the GNSS region, the course over ground and the GNSS track the odometry
// implies. An accepted solution starts the filter only when a second search within
// confirm_window frames agrees with it through the odometry (the candidate); that search
// re-decides only the first one's finalists. The search is a job: work_per_period bounds its
// work per frame, its result is carried to the frame it finishes in by the odometry; its final
// ICP then takes what the periods have left, its result carried the same way. Owns all its
// state: the job, the candidate, the track of recent odometry / GNSS positions and the retry
// spacing. One entry point per frame (step), everything it reads in a StartupFrame; its
// settings are StartupSearchParams (localizer_params.hpp).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

// Everything one frame's search reads.
struct StartupFrame {
  std::uint32_t frame = 0;
  double t = 0.0;                           // [s]
  std::span<const Vec3f> scan{};            // registration scan (body frame, downsampled)
  std::span<const Vec3f> search_scan{};     // its subsample for the pose search
  std::span<const Vec3f> tracking_scan{};   // the tracking ICP's subsample
  IcpTarget map{};                          // the reference map as an ICP target
  GnssFix gnss{};
  bool course_known = false;                // GNSS course over ground at t ...
  double course = 0.0;                      // ... [rad] ENU yaw
  Vec3d sensor_in_body = Vec3d::Zero();     // LiDAR origin in the body frame (ray checks)
  Pose3d odom_T_body = Pose3d::Identity();  // this frame's odometry pose
  bool filter_needs_start = false;          // an accepted solution must be confirmed to start it
  std::span<std::uint32_t> icp_hints{};     // ICP scratch, >= scan.size()
  StageProbe probe{};
  PeriodWork* work = nullptr;               // the period's budget (nullptr: fixed quota)
};

// The search's diagnostics (LocalizerFrameOutput::search_*).
struct StartupSearchReport {
  bool searched = false;
  bool heading_used = false;
  double region = 0.0;  // [m] radius of the region searched around the GNSS fix
  double best_tight = 0.0, runner_up_tight = 0.0;
  double best_conflicts = -1.0, runner_up_conflicts = -1.0;
  Pose3d best_pose = Pose3d::Identity();
  Pose3d runner_up_pose = Pose3d::Identity();
};

enum class StartupStatus : std::uint8_t {
  kNotDue,       // no GNSS yet, or within retry_frames of the last search
  kSearching,    // a search job is running (its work spread over the frames)
  kRejected,     // searched; no solution, or one not (yet) trusted (reported, not fused)
  kAccepted,     // a solution for the running filter (gated and fused like a tracking one)
  kStartFilter,  // a confirmed solution: the filter starts at it, then it is gated and fused
};

struct StartupOutcome {
  StartupStatus status = StartupStatus::kNotDue;
  RegistrationResult registration{};
  // kStartFilter: the candidate the registration confirmed, carried to this frame by the odometry
  // (its ICP information and residual; zero information when the basin audit nominated it). The
  // filter starts at both registrations' information-weighted mean (PoseFilter::start_pose).
  RegistrationResult confirmed_candidate{};
  StartupSearchReport report{};
};

// [m] the median distance from `samples` map points (evenly spread over the map's order) to their
// nearest other map point: the map's actual point spacing, which its capacity sets (a map thinned
// to fit holds fewer, farther-apart points). 0 for an empty map; `work` counts the tree's node visits.
double map_point_spacing(const IcpTarget& map, std::uint32_t samples, std::uint64_t& work);

// The pose search's ray-conflict radius on a map of this spacing: at least the configured one, and
// ratio x the spacing (a ray through a sparse wall passes between its points; 0: off).
double conflict_radius_for(double configured, double spacing, double ratio);

class StartupSearch {
 public:
  // final_icp: the tracking ICP, which refines a finished search's pick; gnss_sigma_inflation: the
  // EKF's (EkfGates), applied to the fix's reported sigma for the region's radius.
  void configure(const StartupSearchParams& params, const IcpParams& final_icp, double gnss_sigma_inflation);

  // Every valid frame, before step(): the track sample (odometry and GNSS position) and the
  // retry spacing. A failed odometry breaks the track.
  void on_frame(bool odometry_ok, const Pose3d& odom_T_body, const GnssFix& gnss);
  // scratch: the pose search's (pose_search.hpp), shared with the caller's other searches.
  StartupOutcome step(const StartupFrame& frame, PoseSearchScratch& scratch, LocalizerCounters& counters);

  // Tracking was lost: drop the candidate, search at the next frame.
  void on_track_lost();
  // A pose found next to the tracked one (basin audit): a search must confirm it.
  void nominate(std::uint32_t frame, const Pose3d& pose, const Pose3d& odom_T_body);
  // The unconfirmed candidate carried to this frame by the odometry, when it is a better
  // estimate than the GNSS fix.
  bool candidate_pose(std::uint32_t frame, const Pose3d& odom_T_body, Pose3d& pose) const;
  // Power-up: no filter started yet, within first_frames of the first search (the
  // localizer takes no map clouds meanwhile; the searches' first slices score every hypothesis).
  // Counted from the first search, not from configure(): the ECU may run for seconds before a
  // map exists (no roadside unit in V2X range yet).
  bool first_acquisition_pending(std::uint32_t frame) const {
    return acquisition_ == Acquisition::kNoSearchYet ||
           (acquisition_ == Acquisition::kFirst && frame - first_search_frame_ < params_.first_frames);
  }

 private:
  struct Candidate {                 // an accepted but unconfirmed solution
    bool valid = false;
    std::uint32_t frame = 0;
    Mat4d pose = Mat4d::Identity();  // world_T_body
    Mat4d odom = Mat4d::Identity();  // odom_T_body at that frame
    Mat6d information = Mat6d::Zero();  // its final ICP's (zero: nominated by the basin audit)
    double inlier_rmse = 0.0;
    bool output = false;             // unambiguous: a better estimate than the GNSS fix
    bool contradicted = false;       // it replaced a candidate it disagreed with
    Vec3d region_fix = Vec3d::Zero();          // its search's region centre (the GNSS fix) ...
    Mat4d region_odom = Mat4d::Identity();     // ... and odom_T_body when that fix was taken
  };
  struct TrackSample {               // per frame: odometry and latest GNSS position (2-D)
    double odom_x = 0.0, odom_y = 0.0, gnss_x = 0.0, gnss_y = 0.0;
    bool gnss = false;
  };
  static constexpr std::size_t kTrackFrames = 32;
  struct Search {                    // one finished search's results
    double region = 0.0;             // [m] radius around the GNSS fix the solution must lie in
    PoseSearchParams params{};       // the pose search's, for this frame's region and course
    PoseSearchResult searched{};     // carried to the frame the job finished in
    RegistrationResult best{};       // the basin picked so far
  };
  // The job's life, one state at a time. kIdle -(start)-> kSearch (exhaustive, over the GNSS
  // region), or kConfirm (re-deciding the candidate's finalists); -(job done)-> the final ICP of
  // its pick, kSearchFinalIcp / kConfirmFinalIcp; -(final ICP done)-> kIdle. Dropped (odometry
  // broken, max_frames) or a lost track: kIdle from any state.
  enum class State : std::uint8_t { kIdle, kSearch, kConfirm, kSearchFinalIcp, kConfirmFinalIcp };
  enum class Event : std::uint8_t { kStartSearch, kStartConfirm, kJobDone, kFinalIcpDone, kStop };
  // The power-up window (first_acquisition_pending): no search yet, the first one under way, or a
  // filter started once.
  enum class Acquisition : std::uint8_t { kNoSearchYet, kFirst, kAcquired };

  // The transition function; an event a state does not expect leaves it where it is.
  static State next(State state, Event event);
  void transition(Event event);  // entering kIdle forgets the running job's best pose so far (unless held)
  // The job's best pose so far as the output, when nothing this frame's GNSS track or course
  // says refutes it (accept()'s cheap checks).
  void update_provisional(const StartupFrame& f);
  // What the GNSS says of a pose of this frame: its track through the odometry against the fixes
  // (when enough), its heading against the course; refutes: what accept() refuses on the GNSS alone.
  struct GnssVerdict {
    bool track_known = false;
    double track_distance = 0.0;  // [m] mean, when track_known
    bool heading_agrees = false;  // false without a course
    bool refutes = false;
  };
  GnssVerdict gnss_verdict(const StartupFrame& f, const Mat4d& pose) const;
  void hold_provisional(const StartupFrame& f, const RegistrationResult& answer);
  bool holds_provisional(std::uint32_t frame) const {
    return provisional_held_ && frame <= provisional_held_until_;
  }
  bool start_when_due(const StartupFrame& f, LocalizerCounters& counters);  // kIdle
  void run_job(const StartupFrame& f, PoseSearchScratch& scratch, bool started, StartupSearchReport& report,
               LocalizerCounters& counters);  // kSearch, kConfirm
  void run_final_icp(const StartupFrame& f, StartupOutcome& out, LocalizerCounters& counters);  // the final ICP states
  // A candidate whose confirming search may start in its own period, and that start.
  bool confirms_this_period(const StartupFrame& f) const;
  void confirm_now(const StartupFrame& f, PoseSearchScratch& scratch, StartupOutcome& out, LocalizerCounters& counters);

  std::uint64_t slice_budget(const StartupFrame& f) const;
  // Power-up exception (first_work_per_period > 0): the slices ignore the budget.
  bool first_exempt(std::uint32_t frame) const {
    return first_acquisition_pending(frame) && params_.first_work_per_period > 0;
  }
  // Power-up: a search's first slice scores and climbs every hypothesis, whatever the budget.
  bool first_scores_whole(std::uint32_t frame) const { return first_acquisition_pending(frame); }
  std::uint64_t room_slice(const StartupFrame& f, std::uint64_t floor, std::uint64_t cap) const;
  // The region around the fix before widening, and the same widened by region_scale_.
  double floor_region(const StartupFrame& f) const;
  double widened(double floor) const;
  void widen_region(StartupStatus status, std::uint32_t frame, const RegistrationResult& best);
  void start_job(const StartupFrame& f, LocalizerCounters& counters);
  void finish_job(const StartupFrame& f, StartupSearchReport& report, LocalizerCounters& counters);
  void begin_final_icp(const StartupFrame& f, LocalizerCounters& counters);
  bool continue_final_icp(const StartupFrame& f, LocalizerCounters& counters);
  void take_result(const StartupFrame& f, Search& s) const;
  double distance_from_region_fix(const Mat4d& pose, const Mat4d& odom_T_body) const;
  void resolve_ambiguity(const StartupFrame& f, Search& s, LocalizerCounters& counters) const;
  void keep_finalists(const StartupFrame& f);
  StartupStatus accept(const StartupFrame& f, const Search& s, StartupOutcome& out, LocalizerCounters& counters);
  bool confirm(std::uint32_t frame, const RegistrationResult& result, const Mat4d& odom_T_body, bool output,
               RegistrationResult& confirmed, LocalizerCounters& counters);
  // Mean horizontal distance between the GNSS fixes of the recent frames and the track a pose
  // hypothesis of this frame implies through the odometry; false when too few fixes.
  bool track_gnss_distance(const Mat4d& pose, const Mat4d& odom_T_body, double& mean_distance) const;

  StartupSearchParams params_{};
  IcpParams final_icp_{};
  double gnss_sigma_inflation_ = 1.0;
  State state_ = State::kIdle;
  Acquisition acquisition_ = Acquisition::kNoSearchYet;
  std::uint32_t first_search_frame_ = 0;  // the frame the first search started in (kFirst)
  Candidate candidate_{};
  TrackSample track_[kTrackFrames];
  std::uint32_t track_count_ = 0;    // consecutive samples pushed (reset by odometry failures)
  std::uint32_t frames_since_search_ = 0;
  // The running search job and what its result needs: the frame it started at and that frame's
  // odometry pose (to carry the result), its region and parameters.
  PoseSearch job_;
  ProximityGrid grid_;               // the job's hypothesis scoring
  // The odometry failed since the job started: its result cannot be carried, the next step drops it.
  bool job_track_broken_ = false;
  std::uint32_t job_frame_ = 0;
  Mat4d job_odom_ = Mat4d::Identity();
  double job_region_ = 0.0;
  double region_scale_ = 1.0;        // grows after a search found nothing acceptable (widen_region)
  double job_floor_region_ = 0.0;    // [m] the job's region before widening (provisional output)
  Vec3d job_fix_ = Vec3d::Zero();    // the GNSS fix the job searches around
  // The GNSS region a result must lie in (accept): its centre and the odometry pose at that fix.
  Vec3d region_fix_ = Vec3d::Zero();
  Mat4d region_odom_ = Mat4d::Identity();
  PoseSearchParams job_params_{};
  bool job_heading_used_ = false;
  // The output before a candidate (output only): the running search's best pose so far, unless
  // the GNSS track or course refutes it (the previous one stays); after a search that ended
  // ambiguous, held until the next search has its own, for at most confirm_window frames.
  bool provisional_valid_ = false;
  Mat4d provisional_ = Mat4d::Identity();       // world_T_body at provisional_odom_
  Mat4d provisional_odom_ = Mat4d::Identity();  // odom_T_body of the frame it belongs to
  std::uint32_t provisional_job_ = 0;           // job_frame_ of the search that found it
  bool provisional_held_ = false;
  std::uint32_t provisional_held_until_ = 0;    // [frame] the hold's last frame
  // The candidate's search finalists (world_T_body at candidate_.frame), winner first.
  Mat4d finalists_[kPoseSearchRefine];
  std::uint32_t finalist_count_ = 0;
  double finalists_ground_z_ = 0.0;
  // The finished job's pick (final_) refined by the tracking ICP in slices like the job's (a whole
  // one costs up to final_icp_.max_work): on a copy of the tracking subsample of the frame the job
  // finished in (final_frame_, final_odom_), its result carried from there by the odometry.
  Search final_{};
  IcpRun final_run_{};
  std::uint32_t final_frame_ = 0;
  Mat4d final_odom_ = Mat4d::Identity();
  FixedVector<Vec3f, config::kMaxSearchPoints> final_scan_;
  std::uint32_t final_hints_[config::kMaxSearchPoints];
};

}  // namespace v2xloc
