#include "v2xloc/algo/localization/scan_ingest.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/coarsening_step.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"
#include "v2xloc/algo/core/unroll.hpp"
#include "v2xloc/algo/localization/deskew.hpp"

namespace v2xloc {

ScanIngest::Accumulator* ScanIngest::find_or_add(const std::int32_t key[3]) {
  Accumulator* found = nullptr;
  linear_probe(spatial_hash_folded(key), kSlots, static_cast<std::uint32_t>(config::kVoxelMaxProbes), [&](std::size_t slot) {
    const std::uint32_t v = slots_[slot];
    if (v == 0) {
      if (count_ == kMaxVoxels) return true;  // full: counted by the caller
      Accumulator& a = voxels_[count_];
      a = Accumulator{{key[0], key[1], key[2]}, 0, static_cast<std::uint32_t>(slot), {0.0, 0.0, 0.0}, 0.0};
      slots_[slot] = static_cast<std::uint32_t>(++count_);
      found = &a;
      return true;
    }
    Accumulator& a = voxels_[v - 1];
    if (a.key[0] == key[0] && a.key[1] == key[1] && a.key[2] == key[2]) {
      found = &a;
      return true;
    }
    return false;
  });
  return found;
}

// One pass over the returns (see the header), specialised on whether times are given. The
// finite and range tests share one comparison on the fast path (NaN and Inf fail it); a return
// failing it is classified in the order of the full tests. stop_when_full: a pass that will be
// read again coarser ends at its first capacity drop (the rest of the sweep would change nothing).
// Returns the returns it read.
template <bool kTimes>
std::size_t ScanIngest::accumulate(std::span<const Vec3f> points, const float* times, const ScanIngestParams& params,
                                   bool stop_when_full, ScanIngestResult& r) {
  const float min2 = params.min_range * params.min_range;
  const float max2 = params.max_range * params.max_range;
  const float inv = 1.0f / params.voxel;  // keys stay within +-max_range / voxel: no overflow
  Accumulator* last = nullptr;  // consecutive returns usually share a voxel: skip the lookup
  std::int32_t last_key[3] = {0, 0, 0};
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    const float t = kTimes ? times[i] : 0.0f;
    const float r2 = p.squaredNorm();
    if (!(r2 >= min2 && r2 <= max2) || (kTimes && !std::isfinite(t))) {
      if (!is_finite_point(p) || (kTimes && !std::isfinite(t))) {
        ++r.non_finite_dropped;
        continue;
      }
      if (r2 < min2 || r2 > max2) {
        ++r.range_dropped;
        continue;
      }
    }
    const std::int32_t key[3] = {det::floor_to_int(p.x() * inv), det::floor_to_int(p.y() * inv),
                                 det::floor_to_int(p.z() * inv)};
    Accumulator* a = last;
    if (a == nullptr || key[0] != last_key[0] || key[1] != last_key[1] || key[2] != last_key[2]) {
      a = find_or_add(key);
      if (a == nullptr) {
        ++r.capacity_dropped;
        if (stop_when_full) return i + 1;
        continue;
      }
      last = a;
      for (int k = 0; k < 3; ++k) last_key[k] = key[k];
    }
    ++a->count;
    V2XLOC_UNROLL_AXES for (int k = 0; k < 3; ++k) a->sum[k] += p[k];
    a->time_sum += t;
  }
  return points.size();
}

// The finest step at most the previous run's at which its voxels, x 81/64 per step finer, fit.
std::uint32_t ScanIngest::first_step(const ScanIngestParams& params) const {
  return finest_fitting_step(last_step_, params.max_coarsen_steps, static_cast<double>(last_count_), 81.0 / 64.0,
                             static_cast<double>(kMaxVoxels));
}

// Steps coarser than `step` for a pass that filled the table after `read` of `total` returns: the
// sweep's voxels extrapolated from the part read (a sweep meets its voxels about evenly in firing
// order), thinned by the surface law (x 64/81 per step coarser) until they fit, at least one step.
// A jump of several steps happens only for a sweep far over the capacity (a first sweep with no
// history: one partial read instead of one per step); a near miss steps once. The pass that
// follows still checks the estimate: a sweep that overflows again steps on.
std::uint32_t ScanIngest::steps_to_fit(std::size_t read, std::size_t total, std::uint32_t step,
                                       std::uint32_t max_steps) {
  double voxels = static_cast<double>(kMaxVoxels) * static_cast<double>(total) /
                  static_cast<double>(read > 0 ? read : 1);
  std::uint32_t skip = 0;
  do {
    ++skip;
    voxels *= 64.0 / 81.0;
  } while (voxels > static_cast<double>(kMaxVoxels) && step + skip < max_steps);
  return skip;
}

ScanIngestResult ScanIngest::run(std::span<const Vec3f> points, std::span<const float> times,
                                 const Mat4d* delta_lidar, const ScanIngestParams& params) {
  ScanIngestResult r;
  r.input_points = static_cast<std::uint32_t>(points.size());
  count_ = 0;
  if (!(params.voxel > 0.0f) || !std::isfinite(params.voxel)) return r;
  const bool has_times = times.size() == points.size() && !points.empty();
  ScanIngestParams p = params;
  std::uint32_t step = first_step(params);
  for (std::uint32_t k = 0; k < step; ++k) p.voxel *= 1.125f;  // the same roundings as step by step
  r.coarsened = step;
  for (;;) {
    const bool last_try = step >= params.max_coarsen_steps;
    const std::size_t read = has_times ? accumulate<true>(points, times.data(), p, !last_try, r)
                                       : accumulate<false>(points, nullptr, p, !last_try, r);
    ++r.passes;
    if (r.capacity_dropped == 0 || last_try) break;
    // Full: whole azimuth sectors would be lost; the sweep is read again with a coarser voxel.
    const std::uint32_t skip = steps_to_fit(read, points.size(), step, params.max_coarsen_steps);
    for (std::size_t v = 0; v < count_; ++v) slots_[voxels_[v].slot] = 0;
    count_ = 0;
    r.non_finite_dropped = r.range_dropped = r.capacity_dropped = 0;
    for (std::uint32_t k = 0; k < skip; ++k) p.voxel *= 1.125f;
    step += skip;
    r.coarsened += skip;
  }
  last_step_ = r.coarsened;
  last_count_ = count_;
  r.voxel = p.voxel;
  for (std::size_t v = 0; v < count_; ++v) {
    const Accumulator& a = voxels_[v];
    const double n = static_cast<double>(a.count);
    points_[v] = Vec3f(static_cast<float>(a.sum[0] / n), static_cast<float>(a.sum[1] / n),
                       static_cast<float>(a.sum[2] / n));
    times_[v] = static_cast<float>(a.time_sum / n);
    slots_[a.slot] = 0;  // leave the table empty for the next scan
  }
  r.voxels = static_cast<std::uint32_t>(count_);
  if (has_times && delta_lidar != nullptr && count_ > 0) {
    DeskewParams dp;
    dp.reference_time = 0.0;
    dp.delta_duration = params.frame_period;
    const std::span<Vec3f> out(points_, count_);
    const DeskewResult d = deskew(out, std::span<const float>(times_, count_), *delta_lidar, dp, out);
    r.deskewed = d.status == DeskewStatus::kOk;
  }
  return r;
}

}  // namespace v2xloc
