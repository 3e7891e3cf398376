#include "v2xloc/algo/localization/trajectory_backfill.hpp"

#include "v2xloc/algo/core/rigid_motion.hpp"

namespace v2xloc {

void TrajectoryBackfill::reset() {
  head_ = 0;
  count_ = 0;
  counters_ = {};
}

BackfillSample& TrajectoryBackfill::at(std::size_t age) {
  return ring_[(head_ + kCapacity - 1 - age) % kCapacity];
}

const BackfillSample* TrajectoryBackfill::find(std::uint32_t frame) const {
  for (std::size_t age = 0; age < count_; ++age) {
    const BackfillSample& s = ring_[(head_ + kCapacity - 1 - age) % kCapacity];
    if (s.frame == frame) return &s;
    if (s.frame < frame) return nullptr;  // frames increase towards the newest
  }
  return nullptr;
}

std::uint32_t TrajectoryBackfill::push(const BackfillSample& sample) {
  if (count_ == kCapacity) {
    const BackfillSample& leaving = ring_[head_];  // the oldest: its pose is final now
    if (!leaving.anchored && !leaving.revised) ++counters_.unrevised_frames;
  }
  ring_[head_] = sample;
  ring_[head_].revised = false;
  head_ = (head_ + 1) % kCapacity;
  if (count_ < kCapacity) ++count_;

  if (!sample.anchored || count_ < 2 || at(1).anchored) return 0;
  // The filter (re)started here: walk back while the odometry chain is unbroken. A frame whose
  // odometry failed is not linked to its predecessor, so the walk stops before that predecessor.
  const Mat4d world_T_odom = sample.world_T_body * se3_inverse(sample.odom_T_body);
  std::uint32_t revised = 0;
  bool linked = sample.odometry_ok;
  for (std::size_t age = 1; age < count_ && linked; ++age) {
    BackfillSample& s = at(age);
    if (s.anchored) break;
    s.world_T_body = world_T_odom * s.odom_T_body;
    s.revised = true;
    ++revised;
    linked = s.odometry_ok;
  }
  if (revised > 0) {
    ++counters_.anchors;
    counters_.revised_frames += revised;
  }
  return revised;
}

bool TrajectoryBackfill::pose(std::uint32_t frame, Mat4d& world_T_body, bool& revised) const {
  const BackfillSample* s = find(frame);
  if (s == nullptr) return false;
  world_T_body = s->world_T_body;
  revised = s->revised;
  return true;
}

}  // namespace v2xloc
