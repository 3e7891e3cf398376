// Tracking: the registration scan to the map by ICP from the filter's prediction, the periodic
// basin audit (basin_audit.hpp), a new track's contest with a rival basin (rival_basin.hpp) and, with the LiDAR + stereo configuration, the stereo cloud by
// ICP from the same prediction. It registers only; the caller fuses (pose_filter.hpp), withholds
// a contested track's registrations and acts on a basin switch (audit or rival). One entry point per tracked frame (step).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/basin_audit.hpp"
#include "v2xloc/algo/localization/period_work.hpp"
#include "v2xloc/algo/localization/rival_basin.hpp"
#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/registration/icp.hpp"
#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc {

struct TrackingFrame {
  Pose3d predicted = Pose3d::Identity();  // the filter's pose at the frame time
  std::span<const Vec3f> scan{};          // registration scan (body frame, downsampled)
  std::span<const Vec3f> tracking_scan{}; // its even subsample the tracking ICP registers
  std::span<const Vec3f> search_scan{};   // its subsample (audit)
  std::span<const Vec3f> stereo_cloud{};  // body frame, downsampled; empty: no stereo
  IcpTarget map{};
  Vec3d sensor_in_body = Vec3d::Zero();
  std::span<std::uint32_t> icp_hints{};   // ICP scratch, >= scan.size()
  StageProbe probe{};
  std::uint32_t frame = 0;                  // localizer frame index
  Pose3d odom_T_body = Pose3d::Identity();  // this frame's odometry pose
  bool map_busy = false;                    // map clouds were fused this period (reference_map.hpp)
  PeriodWork* work = nullptr;               // the period's estimated work (nullptr: fixed quotas)
};

struct TrackingOutcome {
  RegistrationResult registration{};  // not ok: failed, too rough, or a wrong basin (audit)
  AuditOutcome audit{};               // switch_basin also when the rival basin won (rival_basin.hpp)
  bool contested = false;             // the track's rival basin is not decided yet: withhold
  bool stereo_attempted = false;
  RegistrationResult stereo{};
};

class TrackingRegistration {
 public:
  // audit, search: the basin audit's own and the start-up search's pose search (basin_audit.hpp).
  void configure(const TrackingParams& params, const BasinAuditParams& audit, const PoseSearchParams& search);
  // scratch: the basin audit's pose search scratch (pose_search.hpp).
  TrackingOutcome step(const TrackingFrame& frame, PoseSearchScratch& scratch, LocalizerCounters& counters);
  void on_track_lost() {
    audit_.cancel();
    rival_.reset();
  }
  // The start-up search's hypotheses and the filter's start (rival_basin.hpp).
  RivalBasin& rival() { return rival_; }

 private:
  void check_rival(const TrackingFrame& f, TrackingOutcome& out, LocalizerCounters& counters);
  void run_audit(const TrackingFrame& f, TrackingOutcome& out, PoseSearchScratch& scratch, LocalizerCounters& counters);

  TrackingParams params_{};
  BasinAudit audit_{};
  RivalBasin rival_{};
};

}  // namespace v2xloc
