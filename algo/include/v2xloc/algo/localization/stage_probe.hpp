// Stage boundaries of one localizer period, reported to an optional observer. The core reads no
// clock and counts no instructions: a host tool (v2xloc-eval --timing, the callgrind frame
// script) installs a probe and measures between the marks. mark(stage) means "from here on the
// work belongs to `stage`"; kIdle closes the period's last stage. Without a probe a mark is one
// predictable branch.
#pragma once

#include <cstdint>

namespace v2xloc {

enum class LocalizerStage : std::uint8_t {
  kIdle,          // outside the localizer (host I/O, decoding)
  kInputs,        // vehicle signals and GNSS fixes (EKF predictions and updates)
  kMapInsert,     // on_map_cloud: transform, downsample, consistency check
  kScanPrep,      // range filter, deskew, stereo cloud
  kOdometry,      // LiDAR odometry (scan-to-local-map ICP)
  kMapRefresh,    // reference map: expire, extract, search structure, normals
  kDownsample,    // body-frame scan for registration
  kTracking,      // tracking ICP (+ stereo ICP)
  kAudit,         // basin audit (local exhaustive pose search)
  kGlobalSearch,  // start-up / lost-track search (pose search, final ICP)
  kFusion,        // validity gate, EKF registration updates, output
  kCount,
};

inline const char* stage_name(LocalizerStage s) {
  switch (s) {
    case LocalizerStage::kIdle: return "idle";
    case LocalizerStage::kInputs: return "inputs";
    case LocalizerStage::kMapInsert: return "map_insert";
    case LocalizerStage::kScanPrep: return "scan_prep";
    case LocalizerStage::kOdometry: return "odometry";
    case LocalizerStage::kMapRefresh: return "map_refresh";
    case LocalizerStage::kDownsample: return "downsample";
    case LocalizerStage::kTracking: return "tracking";
    case LocalizerStage::kAudit: return "audit";
    case LocalizerStage::kGlobalSearch: return "global_search";
    case LocalizerStage::kFusion: return "fusion";
    case LocalizerStage::kCount: break;
  }
  return "?";
}

struct StageProbe {
  void (*mark)(void* context, LocalizerStage stage) = nullptr;
  void* context = nullptr;
  void operator()(LocalizerStage stage) const {
    if (mark != nullptr) mark(context, stage);
  }
};

}  // namespace v2xloc
