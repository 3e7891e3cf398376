#include "v2xloc/algo/localization/startup_search.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {
namespace {

double horizontal_distance(const Mat4d& pose, const Vec3d& enu) {
  const double dx = pose(0, 3) - enu.x(), dy = pose(1, 3) - enu.y();
  return std::sqrt(dx * dx + dy * dy);
}

constexpr std::uint32_t kMaxSpacingSamples = 256;

}  // namespace

double map_point_spacing(const IcpTarget& map, std::uint32_t samples, std::uint64_t& work) {
  const std::size_t n = map.points.size();
  if (map.tree == nullptr || n < 2 || samples == 0) return 0.0;
  const std::uint32_t want = samples < kMaxSpacingSamples ? samples : kMaxSpacingSamples;
  const std::uint64_t k = want < n ? want : n;
  double d[kMaxSpacingSamples];
  std::uint32_t m = 0;
  Neighbor nb[2];
  for (std::size_t j = 0; j < n && m < k; ++j) {
    if (!kept_evenly(j, n, k)) continue;
    const KdQueryResult r = map.tree->knn(map.points[j], 2, std::span<Neighbor>(nb, 2));
    work += 1 + r.node_visits;
    if (r.count == 2) d[m++] = std::sqrt(static_cast<double>(nb[1].squared_distance));
  }
  if (m == 0) return 0.0;
  std::nth_element(d, d + m / 2, d + m);  // the median's value is the same whatever the algorithm
  return d[m / 2];
}

double conflict_radius_for(double configured, double spacing, double ratio) {
  const double scaled = ratio * spacing;
  return scaled > configured ? scaled : configured;
}

void StartupSearch::configure(const StartupSearchParams& params, const IcpParams& final_icp,
                              double gnss_sigma_inflation) {
  params_ = params;
  final_icp_ = final_icp;
  gnss_sigma_inflation_ = gnss_sigma_inflation;
  candidate_ = {};
  track_count_ = 0;
  frames_since_search_ = params.retry_frames;  // allow a search at the first frame
  provisional_held_ = false;
  transition(Event::kStop);
  finalist_count_ = 0;
  acquisition_ = Acquisition::kNoSearchYet;
  first_search_frame_ = 0;
  region_scale_ = 1.0;
  job_.set_proximity_grid(&grid_);
}

void StartupSearch::on_frame(bool odometry_ok, const Pose3d& odom_T_body, const GnssFix& gnss) {
  ++frames_since_search_;
  if (!odometry_ok) {
    track_count_ = 0;  // the odometry track is broken: start a new one
    job_track_broken_ = true;  // a running job's result can no longer be carried
    provisional_held_ = false;  // nor a held pose
    return;
  }
  TrackSample& s = track_[track_count_ % kTrackFrames];
  s.odom_x = odom_T_body(0, 3);
  s.odom_y = odom_T_body(1, 3);
  s.gnss = gnss.valid;
  s.gnss_x = gnss.enu.x();
  s.gnss_y = gnss.enu.y();
  ++track_count_;
}

void StartupSearch::on_track_lost() {
  candidate_.valid = false;
  finalist_count_ = 0;
  provisional_held_ = false;
  transition(Event::kStop);
  frames_since_search_ = params_.retry_frames;
  region_scale_ = 1.0;
}

void StartupSearch::nominate(std::uint32_t frame, const Pose3d& pose, const Pose3d& odom_T_body) {
  candidate_.valid = true;
  candidate_.output = true;  // found next to a tracked pose: a better estimate than GNSS
  candidate_.contradicted = false;
  candidate_.frame = frame;
  candidate_.pose = pose.matrix();
  candidate_.odom = odom_T_body.matrix();
  candidate_.information = Mat6d::Zero();
  candidate_.inlier_rmse = 0.0;
  finalist_count_ = 0;  // an exhaustive search must confirm it
}

bool StartupSearch::candidate_pose(std::uint32_t frame, const Pose3d& odom_T_body, Pose3d& pose) const {
  if (!candidate_.valid || !candidate_.output || frame - candidate_.frame > params_.confirm_window) {
    const bool running = state_ == State::kSearch || state_ == State::kSearchFinalIcp;
    if (!provisional_valid_ || !(running || holds_provisional(frame))) return false;
    // The best pose so far, carried from the frame it belongs to; from a widened search only
    // inside the normal region (beyond it nothing but the scan match vouches for it).
    if (!provisional_held_ && horizontal_distance(provisional_, job_fix_) > job_floor_region_) return false;
    pose = Pose3d(carried_by_odometry(provisional_, provisional_odom_, odom_T_body.matrix()));
    return true;
  }
  pose = Pose3d(carried_by_odometry(candidate_.pose, candidate_.odom, odom_T_body.matrix()));
  return true;
}

StartupSearch::State StartupSearch::next(State state, Event event) {
  switch (event) {
    case Event::kStartSearch: return state == State::kIdle ? State::kSearch : state;
    case Event::kStartConfirm: return state == State::kIdle ? State::kConfirm : state;
    case Event::kJobDone:
      return state == State::kSearch ? State::kSearchFinalIcp : state == State::kConfirm ? State::kConfirmFinalIcp : state;
    case Event::kFinalIcpDone:
      return state == State::kSearchFinalIcp || state == State::kConfirmFinalIcp ? State::kIdle : state;
    case Event::kStop: return State::kIdle;
  }
  return state;
}

void StartupSearch::transition(Event event) {
  state_ = next(state_, event);
  if (state_ == State::kIdle && !provisional_held_) provisional_valid_ = false;  // it belongs to a job
}

void StartupSearch::update_provisional(const StartupFrame& f) {
  Mat4d pose;
  if (!job_.provisional(pose)) {
    // Refuted by its own refinement (or none yet): a pose held from the last search stays.
    if (!holds_provisional(f.frame) || provisional_job_ == job_frame_) provisional_valid_ = provisional_held_ = false;
    return;
  }
  if (gnss_verdict(f, carried_by_odometry(pose, job_odom_, f.odom_T_body.matrix())).refutes) return;
  provisional_ = pose;
  provisional_odom_ = job_odom_;
  provisional_job_ = job_frame_;
  provisional_valid_ = true;
  provisional_held_ = false;
}

// A search that refused its answer refutes only that pose: its best pose so far stays the output
// until the next search has one (the GNSS fix is metres off), unless it is the refused answer
// itself (an ambiguity refutes neither of its poses).
void StartupSearch::hold_provisional(const StartupFrame& f, const RegistrationResult& answer) {
  if (!provisional_valid_ || provisional_job_ != job_frame_) return;
  const Mat4d now = carried_by_odometry(provisional_, provisional_odom_, f.odom_T_body.matrix());
  const bool ambiguous = final_.searched.best.ok() && !final_.best.ok();
  const bool other_pose = horizontal_distance(now, answer.transform.topRightCorner<3, 1>()) > params_.confirm_distance;
  if (!(ambiguous || other_pose) || gnss_verdict(f, now).refutes) return;
  provisional_held_ = true;
  provisional_held_until_ = f.frame + params_.confirm_window;
}

StartupSearch::GnssVerdict StartupSearch::gnss_verdict(const StartupFrame& f, const Mat4d& pose) const {
  GnssVerdict v;
  v.track_known = track_gnss_distance(pose, f.odom_T_body.matrix(), v.track_distance);
  v.heading_agrees = f.course_known && std::abs(det::wrap_pi(yaw_of(pose.topLeftCorner<3, 3>()) - f.course)) <=
                                           params_.heading_tolerance;
  v.refutes = (v.track_known && v.track_distance > params_.track_max_distance) || (f.course_known && !v.heading_agrees);
  return v;
}

// One period of the search: the job (started when due), then, in the period it finishes, the
// ambiguity check, the final ICP and the acceptance checks the symmetric intersection needs
// (inside the GNSS uncertainty region, enough of the scan explained). Each state's work runs
// in its own method; a state finished hands over to the next within the period.
StartupOutcome StartupSearch::step(const StartupFrame& f, PoseSearchScratch& scratch, LocalizerCounters& counters) {
  StartupOutcome out;
  if (state_ != State::kIdle && (job_track_broken_ || f.frame - job_frame_ >= params_.max_frames)) {
    transition(Event::kStop);  // its result could not be carried here, or it took too long
    ++counters.global_searches_dropped;
  }
  const bool started = state_ == State::kIdle && start_when_due(f, counters);
  if (state_ == State::kIdle) return out;
  if (!started) f.probe(LocalizerStage::kGlobalSearch);
  if (state_ == State::kSearch || state_ == State::kConfirm) run_job(f, scratch, started, out.report, counters);
  if (state_ == State::kSearchFinalIcp || state_ == State::kConfirmFinalIcp) run_final_icp(f, out, counters);
  if (state_ == State::kIdle && confirms_this_period(f) && start_when_due(f, counters)) confirm_now(f, scratch, out, counters);
  if (state_ != State::kIdle && out.status == StartupStatus::kNotDue) out.status = StartupStatus::kSearching;
  f.probe(LocalizerStage::kFusion);
  return out;
}

// A candidate made this period from a final ICP on an earlier frame's scan (the search or its
// final ICP ran out of room): this frame's scan is another view, so its confirming search need not
// wait a period for the next one.
bool StartupSearch::confirms_this_period(const StartupFrame& f) const {
  return candidate_.valid && candidate_.frame == f.frame && finalist_count_ > 0 && final_frame_ != f.frame;
}

// The confirming search's first slice in the candidate's period (and its final ICP, should it
// finish). The candidate's outcome is the period's unless the confirmation decides.
void StartupSearch::confirm_now(const StartupFrame& f, PoseSearchScratch& scratch, StartupOutcome& out,
                                LocalizerCounters& counters) {
  StartupOutcome confirming;
  run_job(f, scratch, true, confirming.report, counters);
  if (state_ == State::kConfirmFinalIcp) run_final_icp(f, confirming, counters);
  if (confirming.report.searched) out.report = confirming.report;
  if (state_ == State::kIdle) {
    out.status = confirming.status;
    out.registration = confirming.registration;
    out.confirmed_candidate = confirming.confirmed_candidate;
  }
}

// kIdle: a job starts with a GNSS fix, retry_frames after the last one, in a period with
// room for its set-up (road height over the whole map, the proximity grid: one piece; the first
// acquisition does not wait). True when one started.
bool StartupSearch::start_when_due(const StartupFrame& f, LocalizerCounters& counters) {
  if (!f.gnss.valid || frames_since_search_ < params_.retry_frames) return false;
  if (!first_acquisition_pending(f.frame) && f.work != nullptr && f.work->left() < f.work->params().search_start) return false;
  frames_since_search_ = 0;
  if (acquisition_ == Acquisition::kNoSearchYet) {
    acquisition_ = Acquisition::kFirst;
    first_search_frame_ = f.frame;
  }
  f.probe(LocalizerStage::kGlobalSearch);
  ++counters.global_searches;
  start_job(f, counters);
  return true;
}

// kSearch / kConfirm: this period's slice of the job, counting the set-up start_job() did (a new
// job's work starts at 0). Done, its result is taken and the final ICP begins.
void StartupSearch::run_job(const StartupFrame& f, PoseSearchScratch& scratch, bool started, StartupSearchReport& report,
                            LocalizerCounters& counters) {
  const std::uint64_t before = started ? 0 : job_.work();
  const bool finished = job_.step(f.map, scratch, slice_budget(f), first_scores_whole(f.frame));
  const std::uint64_t spent = job_.work() - before;
  if (f.work != nullptr) f.work->add(static_cast<double>(spent) * f.work->params().search_unit);
  counters.global_search_work += spent;
  if (!finished) {
    if (state_ == State::kSearch) update_provisional(f);
    return;
  }
  finish_job(f, report, counters);
  transition(Event::kJobDone);
}

// kSearchFinalIcp / kConfirmFinalIcp: this period's slice of the final ICP (out of room: it goes
// on in the next period). Done, the acceptance checks decide the outcome and the search is idle.
void StartupSearch::run_final_icp(const StartupFrame& f, StartupOutcome& out, LocalizerCounters& counters) {
  if (!continue_final_icp(f, counters)) {
    ++counters.global_final_icp_paused;
    return;
  }
  const bool exhaustive = state_ == State::kSearchFinalIcp;
  out.status = accept(f, final_, out, counters);
  const bool candidate_now = candidate_.valid && candidate_.frame == f.frame;
  if (exhaustive && out.status == StartupStatus::kRejected && !candidate_now) hold_provisional(f, out.registration);
  transition(Event::kFinalIcpDone);
  if (out.status == StartupStatus::kStartFilter) acquisition_ = Acquisition::kAcquired;
  if (exhaustive) widen_region(out.status, f.frame, final_.searched.best);
  if (out.status != StartupStatus::kRejected || !candidate_now) return;
  if (exhaustive || !candidate_.contradicted) {
    keep_finalists(f);
    return;
  }
  // The candidate's own finalists, re-decided, disagree with it through the odometry: neither
  // pose is to be trusted, and re-deciding the same finalists again would only repeat them.
  candidate_.output = false;
  finalist_count_ = 0;  // the next search is exhaustive
}

// The period the job finishes in: its result carried here, the ambiguity check, the report,
// then the final ICP begins.
void StartupSearch::finish_job(const StartupFrame& f, StartupSearchReport& r, LocalizerCounters& counters) {
  final_ = Search{};
  take_result(f, final_);
  resolve_ambiguity(f, final_, counters);
  const Search& s = final_;
  r.searched = true;
  r.heading_used = job_heading_used_;
  r.region = job_region_;
  r.best_tight = s.searched.best_tight_fitness;
  r.runner_up_tight = s.searched.runner_up_tight_fitness;
  r.best_conflicts = s.searched.best_conflicts;
  r.runner_up_conflicts = s.searched.runner_up_conflicts;
  r.best_pose = Pose3d(s.searched.best.transform);
  r.runner_up_pose = Pose3d(s.searched.runner_up.transform);
  begin_final_icp(f, counters);
}

// (2) The tracking ICP from the pick, on this frame's tracking subsample (the registration scan
// without one). Up to final_icp_.max_work (~44 M instructions from a poor start): run in slices
// on a copy of the scan; a scan larger than the copy is refined at once, as a tracking ICP would be.
void StartupSearch::begin_final_icp(const StartupFrame& f, LocalizerCounters& counters) {
  final_frame_ = f.frame;
  final_odom_ = f.odom_T_body.matrix();
  final_scan_.clear();
  final_run_ = IcpRun{};
  final_run_.result = final_.best;  // not ok: nothing to refine (finished)
  if (!final_.best.ok()) return;
  const std::span<const Vec3f> scan = f.tracking_scan.empty() ? f.scan : f.tracking_scan;
  if (scan.size() > final_scan_.capacity()) {
    final_run_.result = icp(scan, f.map, final_.best.transform, final_icp_, f.icp_hints);
    const std::uint64_t work = final_run_.result.node_visits + (final_run_.result.iterations + 1) * scan.size();
    counters.global_search_work += work;
    if (f.work != nullptr) f.work->add(static_cast<double>(work) * f.work->params().search_unit);
    return;
  }
  for (const Vec3f& p : scan) final_scan_.push_back(p);
  icp_begin(final_run_, final_scan_.span(), f.map, final_.best.transform, final_icp_,
            std::span<std::uint32_t>(final_hints_, final_scan_.size()));
}

// One period's slice of the final ICP, counted as search work: all the period has left, at least
// the job's floor (a short piece: the job's quota keeps the search's steady share); whole without
// a period budget and under the power-up exception (first_exempt). True once finished; out of
// final_icp_.max_work in all it ends kDidNotConverge, as icp() does.
bool StartupSearch::continue_final_icp(const StartupFrame& f, LocalizerCounters& counters) {
  if (final_run_.finished) return true;
  const std::uint64_t cap = final_icp_.max_work > 0 ? final_icp_.max_work : ~std::uint64_t{0};
  const std::uint64_t left = cap > final_run_.work ? cap - final_run_.work : 0;
  const std::uint64_t slice = first_exempt(f.frame)
                                  ? ~std::uint64_t{0}
                                  : room_slice(f, params_.min_work_per_period, ~std::uint64_t{0});
  const std::uint64_t before = final_run_.work;
  bool finished = icp_continue(final_run_, final_scan_.span(), f.map, final_icp_, ~std::uint32_t{0},
                               std::span<std::uint32_t>(final_hints_, final_scan_.size()), slice < left ? slice : left);
  const std::uint64_t spent = final_run_.work - before;
  if (f.work != nullptr) f.work->add(static_cast<double>(spent) * f.work->params().search_unit);
  counters.global_search_work += spent;
  if (!finished && final_run_.work >= cap) {
    final_run_.result.status = RegistrationStatus::kDidNotConverge;  // out of work: as at the iteration cap
    final_run_.finished = finished = true;
  }
  return finished;
}

// This period's slice: what the period has left (period_work.hpp), between the floor that keeps
// the search moving in crowded periods and the fixed quota (all of it without a period budget).
// Under the power-up exception, at least first_work_per_period.
std::uint64_t StartupSearch::slice_budget(const StartupFrame& f) const {
  const std::uint64_t quota = params_.work_per_period;
  if (quota == 0) return ~std::uint64_t{0};
  const std::uint64_t floor = params_.min_work_per_period < quota ? params_.min_work_per_period : quota;
  std::uint64_t slice = room_slice(f, floor, quota);
  if (first_exempt(f.frame) && params_.first_work_per_period > slice) slice = params_.first_work_per_period;
  return slice;
}

// What the period has left, in work units, between floor and cap; cap without a period budget.
std::uint64_t StartupSearch::room_slice(const StartupFrame& f, std::uint64_t floor, std::uint64_t cap) const {
  if (f.work == nullptr || !(f.work->params().search_unit > 0.0)) return cap;
  const double room = f.work->left() / f.work->params().search_unit;
  return room <= static_cast<double>(floor) ? floor
         : room >= static_cast<double>(cap) ? cap
                                            : static_cast<std::uint64_t>(room);
}

double StartupSearch::floor_region(const StartupFrame& f) const {
  const double region = params_.gnss_gate_sigmas * (f.gnss.sigma * gnss_sigma_inflation_ + 1.0);
  return region < params_.min_region ? params_.min_region : region;
}

double StartupSearch::widened(double floor) const {
  if (!(region_scale_ > 1.0)) return floor;
  const double wide = floor * region_scale_;
  const double cap = params_.max_region > floor ? params_.max_region : floor;
  return wide < cap ? wide : cap;
}

// An exhaustive search whose best pose matched nothing well (no candidate set, no filter started,
// its best below min_fitness): the true pose may lie outside the region (a canyon fix
// further off than the floor), so the next search looks wider. A search that matched, even one
// refused as ambiguous, returns to the normal region. The work stays bounded: hypotheses grow
// with the area (45 m: 2.25x), spread over periods like any search.
void StartupSearch::widen_region(StartupStatus status, std::uint32_t frame, const RegistrationResult& best) {
  const bool matched = best.ok() && best.fitness >= params_.min_fitness;
  const bool found = matched || status == StartupStatus::kStartFilter || status == StartupStatus::kAccepted ||
                     (candidate_.valid && candidate_.frame == frame);
  region_scale_ = found ? 1.0 : region_scale_ * params_.region_growth;
  if (!(region_scale_ < 1e3)) region_scale_ = 1e3;  // capped by max_region anyway
}

// (1) Exhaustive, GNSS-seeded search over position and heading; or, to confirm a candidate, the
// candidate's search finalists carried here by the odometry, re-decided on this frame's scan.
void StartupSearch::start_job(const StartupFrame& f, LocalizerCounters& counters) {
  job_floor_region_ = floor_region(f);
  job_region_ = widened(job_floor_region_);
  job_fix_ = f.gnss.enu;
  PoseSearchParams& sp = job_params_;
  sp = params_.search;
  // A widened region (widen_region) may exceed the search's own radius, up to max_region.
  const double radius_cap = region_scale_ > 1.0 && params_.max_region > sp.radius ? params_.max_region
                                                                                       : sp.radius;
  sp.radius = job_region_ < radius_cap ? job_region_ : radius_cap;
  sp.sensor_in_body = f.sensor_in_body;
  if (params_.conflict_radius_per_spacing > 0.0) {
    std::uint64_t spacing_work = 0;
    const double spacing = map_point_spacing(f.map, params_.spacing_samples, spacing_work);
    sp.conflict_radius = conflict_radius_for(sp.conflict_radius, spacing, params_.conflict_radius_per_spacing);
    counters.global_search_work += spacing_work;
    if (f.work != nullptr) f.work->add(static_cast<double>(spacing_work) * f.work->params().search_unit);
  }
  job_heading_used_ = f.course_known;
  if (f.course_known) {
    sp.use_yaw_prior = true;
    sp.yaw_prior = f.course;
    sp.yaw_prior_tolerance = params_.heading_tolerance;
    ++counters.heading_searches;
  }
  sp.provisional = params_.work_per_period > 0;  // a search over several periods outputs its best pose so far
  sp.provisional_scored = sp.provisional && first_scores_whole(f.frame);
  sp.provisional_ambiguity = params_.max_ambiguity;  // a near-tie the rays decide, as resolve_ambiguity's last rule
  sp.provisional_conflict_ratio = params_.conflict_ratio;
  sp.provisional_conflict_margin = params_.conflict_margin;
  job_frame_ = f.frame;
  job_odom_ = f.odom_T_body.matrix();
  job_track_broken_ = false;
  if (!provisional_held_) provisional_valid_ = false;
  const bool confirm_finalists = finalist_count_ > 0 && candidate_.valid &&
                                 f.frame - candidate_.frame <= params_.confirm_window;
  // The GNSS region a result must lie in: around this fix, or for a confirming search around the
  // fix its candidate's search started from (both checked where they were taken).
  region_fix_ = confirm_finalists ? candidate_.region_fix : f.gnss.enu;
  region_odom_ = confirm_finalists ? candidate_.region_odom : job_odom_;
  if (!confirm_finalists) {
    sp.max_offset = job_region_;  // what accept() checks around region_fix_ (this fix, this frame)
    transition(Event::kStartSearch);
    job_.start(f.search_scan, f.map, f.gnss.enu, sp);
    return;
  }
  Mat4d carried[kPoseSearchRefine];
  const Mat4d to_now = se3_inverse(candidate_.odom) * job_odom_;
  for (std::uint32_t i = 0; i < finalist_count_; ++i) carried[i] = finalists_[i] * to_now;
  transition(Event::kStartConfirm);
  job_.start_from_poses(f.search_scan, f.map, std::span<const Mat4d>(carried, finalist_count_), finalists_ground_z_,
                        sp);
}

// The finished job's result, carried from the frame it started at to this one.
void StartupSearch::take_result(const StartupFrame& f, Search& s) const {
  s.region = job_region_;
  s.params = job_params_;
  s.searched = job_.result();
  if (job_frame_ != f.frame) {
    const Mat4d to_now = se3_inverse(job_odom_) * f.odom_T_body.matrix();
    s.searched.best.transform = s.searched.best.transform * to_now;
    s.searched.runner_up.transform = s.searched.runner_up.transform * to_now;
  }
  s.best = s.searched.best;
}

// An ambiguous result is decided by the GNSS track when one pose explains it clearly better, or
// else by the map's negative evidence: of two poses that fit about as well, the one whose rays
// cross mapped surfaces clearly more often (conflicts, pose_search.hpp) is contradicted by the map.
void StartupSearch::resolve_ambiguity(const StartupFrame& f, Search& s, LocalizerCounters& counters) const {
  const PoseSearchResult& searched = s.searched;
  const bool distinct = searched.best_tight_fitness > 0.0 &&
                        searched.runner_up_tight_fitness < params_.max_ambiguity * searched.best_tight_fitness;
  if (distinct) return;
  s.best.status = RegistrationStatus::kDidNotConverge;
  if (!searched.best.ok() || !searched.runner_up.ok()) return;
  const Mat4d& odom = f.odom_T_body.matrix();
  double d_best = 0.0, d_other = 0.0;
  if (track_gnss_distance(searched.best.transform, odom, d_best) &&
      track_gnss_distance(searched.runner_up.transform, odom, d_other)) {
    const double lo = d_best < d_other ? d_best : d_other, hi = d_best < d_other ? d_other : d_best;
    if (lo < params_.track_distance_ratio * hi && hi - lo > params_.track_distance_margin) {
      s.best = d_best < d_other ? searched.best : searched.runner_up;
      ++counters.ambiguities_resolved;
      return;
    }
  }
  const int fewer = clearly_fewer_conflicts(searched.best_conflicts, searched.runner_up_conflicts,
                                           params_.conflict_ratio, params_.conflict_margin);
  if (fewer < 0) return;
  s.best = fewer == 0 ? searched.best : searched.runner_up;
  ++counters.ambiguities_resolved;
}

// A new candidate keeps its search's finalists (carried here) for the confirming search.
void StartupSearch::keep_finalists(const StartupFrame& f) {
  finalist_count_ = job_.finalists(std::span<Mat4d>(finalists_, kPoseSearchRefine));
  finalists_ground_z_ = job_.result().ground_z;
  if (job_frame_ == f.frame) return;
  const Mat4d to_now = se3_inverse(job_odom_) * f.odom_T_body.matrix();
  for (std::uint32_t i = 0; i < finalist_count_; ++i) finalists_[i] = finalists_[i] * to_now;
}

// [m] a pose of this frame (world_T_body; odom_T_body its odometry pose) from the fix the
// search's region is centred on, taken back by the odometry to the frame that fix belongs to: the
// region is where the search looked. A search spread over frames finishes when a canyon fix may
// have jumped by the region's size (firmware, Sim 2 / 2_infra: 24 m off at the search's start, 32
// m four frames later, when the confirming search started).
double StartupSearch::distance_from_region_fix(const Mat4d& pose, const Mat4d& odom_T_body) const {
  if (odom_T_body == region_odom_) return horizontal_distance(pose, region_fix_);
  return horizontal_distance(Mat4d(pose * se3_inverse(odom_T_body) * region_odom_), region_fix_);
}

// (3) The acceptance checks on the final ICP's result (carried to this frame). An accepted
// solution starts a filter that needs it only once a second search confirms it.
StartupStatus StartupSearch::accept(const StartupFrame& f, const Search& s, StartupOutcome& out,
                                    LocalizerCounters& counters) {
  RegistrationResult& result = out.registration;
  if (!s.best.ok()) {
    result = s.best;
    return StartupStatus::kRejected;
  }
  result = final_run_.result;
  if (final_frame_ != f.frame) {
    result.transform = carried_by_odometry(result.transform, final_odom_, f.odom_T_body.matrix());
  }
  if (!result.ok()) return StartupStatus::kRejected;
  const Mat4d& odom = f.odom_T_body.matrix();
  const GnssVerdict gnss = gnss_verdict(f, result.transform);
  if (result.horizontal_constraint < params_.min_horizontal_constraint) {
    ++counters.global_unconstrained;  // an along-street alias fits as well (see the parameter)
    result.status = RegistrationStatus::kDegenerate;
    return StartupStatus::kRejected;
  }
  if (result.fitness < params_.min_fitness || gnss.refutes || distance_from_region_fix(result.transform, odom) > s.region) {
    result.status = RegistrationStatus::kDidNotConverge;
    return StartupStatus::kRejected;
  }
  ++counters.global_accepted;
  if (!f.filter_needs_start) return StartupStatus::kAccepted;
  // An unconfirmed candidate is reported (Reg. column) but neither gated nor fused.
  // Output before confirmation when it is unlikely to be the mirror: the course says so, the
  // GNSS track does, or the search over every heading left no other pose standing (the ray
  // check removed the rest). Still flagged not localized until a second search confirms it.
  const bool sole = !f.course_known && s.params.max_conflicts > 0.0 && s.searched.best.ok() &&
                    s.searched.runner_up_tight_fitness <= 0.0;
  if (!confirm(f.frame, result, odom, gnss.track_known || gnss.heading_agrees || sole, out.confirmed_candidate,
               counters)) {
    return StartupStatus::kRejected;
  }
  return StartupStatus::kStartFilter;
}

// A candidate agrees when it lies within confirm_distance / confirm_yaw of this registration after
// the odometry carried it here; then it is handed on (`confirmed`) as a second estimate of this pose.
bool StartupSearch::confirm(std::uint32_t frame, const RegistrationResult& result, const Mat4d& odom_T_body,
                            bool output, RegistrationResult& confirmed, LocalizerCounters& counters) {
  if (params_.confirm_window == 0) return true;
  const Mat4d& pose = result.transform;
  if (candidate_.valid && frame - candidate_.frame <= params_.confirm_window) {
    const Mat4d predicted = carried_by_odometry(candidate_.pose, candidate_.odom, odom_T_body);
    const double dyaw = det::wrap_pi(yaw_of(pose.topLeftCorner<3, 3>()) - yaw_of(predicted.topLeftCorner<3, 3>()));
    if (horizontal_distance(pose, predicted.topRightCorner<3, 1>()) <= params_.confirm_distance &&
        std::abs(dyaw) <= params_.confirm_yaw) {
      candidate_.valid = false;
      ++counters.global_confirmed;
      confirmed.status = RegistrationStatus::kOk;
      confirmed.transform = predicted;
      confirmed.information = candidate_.information;
      confirmed.inlier_rmse = candidate_.inlier_rmse;
      return true;
    }
    ++counters.global_inconsistent;
  }
  candidate_.contradicted = candidate_.valid && frame - candidate_.frame <= params_.confirm_window;
  candidate_.valid = true;
  candidate_.frame = frame;
  candidate_.pose = pose;
  candidate_.odom = odom_T_body;
  candidate_.information = result.information;
  candidate_.inlier_rmse = result.inlier_rmse;
  candidate_.output = output;
  candidate_.region_fix = region_fix_;
  candidate_.region_odom = region_odom_;
  return false;
}

bool StartupSearch::track_gnss_distance(const Mat4d& pose, const Mat4d& odom_T_body, double& mean_distance) const {
  const std::uint32_t limit = params_.track_frames < kTrackFrames ? params_.track_frames
                                                                  : static_cast<std::uint32_t>(kTrackFrames);
  const std::uint32_t n = track_count_ < limit ? track_count_ : limit;
  const Mat4d world_T_odom = pose * se3_inverse(odom_T_body);
  double sum = 0.0;
  std::uint32_t m = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const TrackSample& s = track_[(track_count_ - 1 - i) % kTrackFrames];
    if (!s.gnss) continue;
    const double x = world_T_odom(0, 0) * s.odom_x + world_T_odom(0, 1) * s.odom_y + world_T_odom(0, 3);
    const double y = world_T_odom(1, 0) * s.odom_x + world_T_odom(1, 1) * s.odom_y + world_T_odom(1, 3);
    sum += std::sqrt((x - s.gnss_x) * (x - s.gnss_x) + (y - s.gnss_y) * (y - s.gnss_y));
    ++m;
  }
  if (m < params_.track_min_fixes) return false;
  mean_distance = sum / m;
  return true;
}

}  // namespace v2xloc
