// Rival basin of a new track. On a sparse map a street's repeated facades can make a start-up
// search's hypotheses 20-30 m apart explain the scan nearly equally (search tight fitness 0.83-0.98
// of the best); whichever the search confirms, its own registrations then look as good as a true
// track's, so the validity gate's envelopes cannot tell (they learn from the track itself), and
// the basin audit's disc does not reach that far. The start-up searches' hypotheses are noted;
// when the filter starts, a noted hypothesis of another basin with contest_ratio of the started
// basin's tight fitness contests the track. While contested, every tracked frame refines the
// rival (carried by the odometry) with the tracking ICP and compares the two on the full scan:
// the track stands when it beats the rival by resolve_ratio, and the rival takes over (a basin
// switch, confirmed by the start-up search as an audit's nomination is) when it beats the track
// by switch_ratio. The caller withholds a contested track's registrations from the filter and
// from validity. The check lives within the period's budget (RivalFrame::budget,
// basin_decision.hpp): a frame whose room holds no decision carries the rival on to the next.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/basin_decision.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

struct RivalFrame {
  Pose3d tracked = Pose3d::Identity();     // this frame's tracking registration (ok)
  std::span<const Vec3f> scan{};           // registration scan: both poses are judged on it
  std::span<const Vec3f> tracking_scan{};  // its subsample the tracking ICP registers
  IcpTarget map{};
  std::span<std::uint32_t> icp_hints{};    // ICP scratch, >= scan.size()
  std::uint32_t frame = 0;                 // localizer frame index
  Pose3d odom_T_body = Pose3d::Identity();  // this frame's odometry pose
  BasinDecisionBudget budget{};  // room and prices (room infinite: the check always completes)
};

struct RivalOutcome {
  bool checked = false;                   // the rival was compared this frame
  bool deferred = false;                  // no decision this frame: the room did not hold one
  std::uint64_t queries = 0;              // nearest-neighbour queries of its ICP
  std::uint64_t evaluated = 0;            // points of its two fitness evaluations
  std::uint32_t stride = 0;               // evaluation subsample stride (1: the whole scan)
  bool switch_basin = false;              // the rival beat the track ...
  Pose3d candidate = Pose3d::Identity();  // ... refined here (world_T_body)
};

class RivalBasin {
 public:
  // search: the start-up search's pose search (distinct basins, tight select distance);
  // icp: the tracking ICP that refines the rival.
  void configure(const RivalBasinParams& params, const PoseSearchParams& search, const IcpParams& icp);
  // Tracking lost: the noted hypotheses and any contest are dropped.
  void reset();
  // A start-up search's hypothesis at this frame (world_T_body) and its search tight fitness.
  void note(const Pose3d& pose, double tight, std::uint32_t frame, const Pose3d& odom_T_body);
  // The filter starts at pose: the strongest noted hypothesis of another basin contests the
  // track when it has contest_ratio of the best noted in the started basin (or of the best noted
  // at all when none was). The notes are then cleared.
  void on_start(const Pose3d& pose, std::uint32_t frame, const Pose3d& odom_T_body);
  bool contested() const { return contested_; }
  RivalOutcome check(const RivalFrame& f);

 private:
  struct Note {
    Mat4d pose = Mat4d::Identity();
    Mat4d odom = Mat4d::Identity();
    double tight = 0.0;
    std::uint32_t frame = 0;
  };
  static constexpr std::size_t kNotes = 8;

  RivalBasinParams params_{};
  PoseSearchParams search_{};
  IcpParams icp_{};
  std::array<Note, kNotes> notes_{};
  std::size_t note_count_ = 0;
  bool contested_ = false;
  PendingBasinDecision pending_{};        // the rival, while contested
};

}  // namespace v2xloc
