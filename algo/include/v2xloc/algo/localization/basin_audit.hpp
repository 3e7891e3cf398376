// The basin audit: every audit_period_frames tracked frames a local exhaustive pose search
// around the tracked pose asks whether tracking sits in an aliased basin (a street repeats
// itself along its length). The search's subsample only nominates another basin; the switch is
// decided on the full scan after the tracking ICP. Owns its period count; one entry point per
// tracked frame (step) with everything it reads in an AuditFrame.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/stage_probe.hpp"
#include "v2xloc/algo/registration/icp.hpp"

namespace v2xloc {

struct AuditFrame {
  Pose3d tracked = Pose3d::Identity();   // this frame's tracking registration (ok)
  std::span<const Vec3f> scan{};         // registration scan (body frame, downsampled)
  std::span<const Vec3f> search_scan{};  // its subsample for the pose search
  IcpTarget map{};
  Vec3d sensor_in_body = Vec3d::Zero();
  std::span<std::uint32_t> icp_hints{};  // ICP scratch, >= scan.size()
  StageProbe probe{};                    // marks kAudit while it runs, then kTracking
};

struct AuditOutcome {
  bool audited = false;                   // the audit ran this frame
  bool switch_basin = false;              // tracking is in a wrong basin ...
  Pose3d candidate = Pose3d::Identity();  // ... and this is the better one (world_T_body)
};

class BasinAudit {
 public:
  void configure(const LocalizerParams& params);
  AuditOutcome step(const AuditFrame& frame, LocalizerCounters& counters);

 private:
  AuditOutcome audit(const AuditFrame& f, LocalizerCounters& counters) const;
  // Refines the nominated basin on the full scan; true when it still differs from the tracked
  // pose and beats it by audit_full_switch_ratio.
  bool wins_on_full_scan(const AuditFrame& f, const Mat4d& nominated, Mat4d& refined) const;

  LocalizerParams params_{};
  std::uint32_t frames_since_audit_ = 0;
};

}  // namespace v2xloc
