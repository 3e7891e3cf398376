// Fixed-lag revision of the output trajectory. Before the filter starts (and after it loses
// track) the localizer can only output the GNSS fix, 8-17 m off in the canyon. Once the filter
// (re)starts at frame j, the odometry, centimetre-accurate over seconds, carries that pose back:
//   world_T_body(k) = world_T_body(j) * odom_T_body(j)^-1 * odom_T_body(k)
// for the unanchored frames k < j still held here and connected to j by successful odometry.
// This is what a fixed-lag smoother gives when the only other information about those frames is
// a fix metres off. Frames the filter already estimated are never rewritten.
// The revised pose of frame k is final once k leaves the buffer (kBackfillFrames frames later):
// consumers that need the live estimate use the localizer's frame output; consumers that can
// wait (trajectory logs, map updates, the evaluation's "Fused (lag)" column) read this one.
#pragma once

#include <cstddef>
#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct BackfillSample {
  std::uint32_t frame = 0;
  Mat4d odom_T_body = Mat4d::Identity();
  Mat4d world_T_body = Mat4d::Identity();  // live output, then the revision if any
  bool anchored = false;  // the filter's own estimate (initialized): never revised
  bool odometry_ok = false;  // the odometry linked this frame to the previous one
  bool revised = false;
};

struct BackfillCounters {
  std::uint32_t anchors = 0;          // filter starts that revised at least one frame
  std::uint32_t revised_frames = 0;
  std::uint32_t unrevised_frames = 0; // unanchored frames that left the buffer as output live
};

class TrajectoryBackfill {
 public:
  static constexpr std::size_t kCapacity = config::kBackfillFrames;

  void reset();
  // Appends one frame's live output (frames in increasing order). When this frame is anchored
  // and the previous one was not, the unanchored frames before it are revised; returns how many.
  std::uint32_t push(const BackfillSample& sample);
  // The latest pose of a frame still held; false when it already left the buffer (or never came).
  bool pose(std::uint32_t frame, Mat4d& world_T_body, bool& revised) const;
  std::size_t size() const { return count_; }
  const BackfillCounters& counters() const { return counters_; }

 private:
  BackfillSample& at(std::size_t age);  // 0: newest
  const BackfillSample* find(std::uint32_t frame) const;

  BackfillSample ring_[kCapacity];
  std::size_t head_ = 0;   // next write slot
  std::size_t count_ = 0;
  BackfillCounters counters_{};
};

}  // namespace v2xloc
