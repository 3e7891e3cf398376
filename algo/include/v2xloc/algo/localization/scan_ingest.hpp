// Scan ingest: the raw sweep is read once and never stored. Each finite return within
// [min_range, max_range] is accumulated into its voxel (LiDAR frame, cubes of `voxel` metres
// keyed from the sensor origin): position sum and firing-time sum. The voxel centroids, in order
// of first occurrence, are then deskewed at their mean firing time (deskew.hpp). Odometry (its
// 0.5 v frame) and the registration to the map (in the body frame) both start from these points:
// one pass over the ~64k returns instead of three, and a capacity set by the voxels a scene
// holds, not by the sensor's return count (the EMBEDDED profile cannot hold a raw 64-beam sweep).
// A scene with more voxels than the capacity is ingested again coarser, the voxel grown by 9/8 a
// step (at most max_coarsen_steps; counted; a pass stops reading where the table fills): dropping
// the returns beyond the capacity would cut the sweep in firing order, i.e. lose whole azimuth
// sectors (EMBEDDED, 4,096 voxels: a whole 64-beam sweep of the recordings holds ~6-8k 0.5 m
// voxels, and a scan without its last sectors locked the start-up search 23 m off along a
// street). Returns still beyond the capacity after the last step are dropped and counted, never
// silently. The host capacity never binds (identical output). Consecutive sweeps of one sensor
// hold nearly the same number of voxels, so a sweep is read from the finest step at which the
// previous sweep would have fit by the surface law (voxels ~ 1 / edge^2: x 81/64 per step
// finer): a finer pass would only fill the table again. The law is rough for a sweep (grid phase:
// a recording's first sweep holds 6.1k, 5.2k, 5.7k, 3.7k voxels over the first four steps), so
// it skips a step only when even it says the step overflows. A sweep far over
// the capacity (the first one, with no history) skips ahead by the same law from the share of the
// sweep that filled the table (steps_to_fit: one partial read instead of one per step; EMBEDDED's
// power-up period 89.7 -> 79.0 M x86-64 instructions, Sim 1 / 4_infra). `coarsened` counts the
// steps from the base voxel either way; `passes` the reads of the sweep (the period's work is priced
// by them: a sweep read once from a coarser step costs one read, not one per step).
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct ScanIngestParams {
  float min_range = 3.0f;         // [m] closer returns are the ego body
  float max_range = 80.0f;        // [m] farther returns are sparse and noisy
  float voxel = 0.5f;             // [m] voxel edge
  double frame_period = 0.1;      // [s] span of the motion `delta` given to run()
  std::uint32_t max_coarsen_steps = 8;  // voxel x 9/8 re-runs while the capacity overflows (<= 2.6 voxel)
};

struct ScanIngestResult {
  std::uint32_t input_points = 0;
  std::uint32_t non_finite_dropped = 0;   // NaN/Inf coordinate (or time, when times are given)
  std::uint32_t range_dropped = 0;        // outside [min_range, max_range]
  std::uint32_t capacity_dropped = 0;     // voxel table full or hash probes exhausted
  std::uint32_t voxels = 0;               // points out
  std::uint32_t coarsened = 0;            // re-runs with the voxel grown by 9/8 (capacity overflow)
  std::uint32_t passes = 0;               // reads of the sweep, a partial one that filled the table included
  float voxel = 0.0f;                     // [m] voxel edge used
  bool deskewed = false;
};

class ScanIngest {
 public:
  // times: per-point firing time [s] since the frame stamp (same size as points, or empty);
  // delta_lidar: the sensor's motion over frame_period (nullptr: no deskew).
  ScanIngestResult run(std::span<const Vec3f> points, std::span<const float> times,
                       const Mat4d* delta_lidar, const ScanIngestParams& params);
  // The next run reads from the base voxel (a new sensor or configuration).
  void forget_steps() {
    last_step_ = 0;
    last_count_ = 0;
  }
  // Voxel centroids of the last run, LiDAR frame, deskewed when the result says so.
  std::span<const Vec3f> points() const { return {points_, count_}; }

 private:
  static constexpr std::size_t kMaxVoxels = config::kMaxDownsampledPoints;
  static constexpr std::size_t kSlots = 4 * kMaxVoxels;  // load <= 1/4: short probe chains
  static_assert((kSlots & (kSlots - 1)) == 0, "hash slots must be a power of two");
  struct Accumulator {
    std::int32_t key[3];
    std::uint32_t count;
    std::uint32_t slot;
    double sum[3];
    double time_sum;
  };
  Accumulator* find_or_add(const std::int32_t key[3]);
  template <bool kTimes>
  std::size_t accumulate(std::span<const Vec3f> points, const float* times, const ScanIngestParams& params,
                  bool stop_when_full, ScanIngestResult& r);

  Accumulator voxels_[kMaxVoxels];
  std::uint32_t slots_[kSlots] = {};  // voxel index + 1, 0 = empty
  Vec3f points_[kMaxVoxels];
  float times_[kMaxVoxels];
  std::size_t count_ = 0;
  std::uint32_t first_step(const ScanIngestParams& params) const;
  static std::uint32_t steps_to_fit(std::size_t read, std::size_t total, std::uint32_t step, std::uint32_t max_steps);
  std::uint32_t last_step_ = 0;   // coarsening steps the previous run needed
  std::size_t last_count_ = 0;    // and its voxels
};

}  // namespace v2xloc
