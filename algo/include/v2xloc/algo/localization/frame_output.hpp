// The frame's pose output. With a running filter: its pose and sigmas, localized when the
// horizontal sigma is within budget. Before the filter starts: an unconfirmed start-up
// candidate carried by the odometry, else the GNSS fix set on the map's road surface (the
// vehicle is on the road; a canyon's GNSS altitude is off by more than its horizontal position)
// and turned to the course over ground when there is one; never localized, with the GNSS sigma.
#pragma once

#include <span>

#include "v2xloc/algo/localization/localizer_params.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"
#include "v2xloc/algo/localization/pose_filter.hpp"

namespace v2xloc {

// What the output reads besides the filter.
struct OutputFrame {
  double t = 0.0;                          // [s]
  GnssFix gnss{};
  bool course_known = false;               // GNSS course over ground at t ...
  double course = 0.0;                     // ... [rad]
  bool map_ready = false;
  std::span<const Vec3f> map_points{};     // the registration target's points (road height)
  bool has_candidate = false;              // an unconfirmed start-up solution to output ...
  Pose3d candidate = Pose3d::Identity();   // ... carried to this frame
};

class FrameOutput {
 public:
  void configure(const FrameOutputParams& params) { params_ = params; }
  void fill(const OutputFrame& frame, const PoseFilter& filter, LocalizerFrameOutput& out,
            LocalizerCounters& counters) const;

 private:
  void fill_from_filter(const PoseFilter& filter, LocalizerFrameOutput& out) const;
  void fill_before_start(const OutputFrame& frame, LocalizerFrameOutput& out, LocalizerCounters& counters) const;

  FrameOutputParams params_{};
};

}  // namespace v2xloc
