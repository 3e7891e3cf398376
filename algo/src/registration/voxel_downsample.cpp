#include "v2xloc/algo/registration/voxel_downsample.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"

namespace v2xloc {
namespace {

constexpr double kMaxVoxelIndex = 2147483520.0;  // < 2^31, exactly representable

}  // namespace

VoxelDownsampleResult voxel_downsample(std::span<const Vec3f> points, float voxel_size,
                                       std::span<VoxelHashSlot> slots,
                                       std::span<VoxelAccumulator> accumulators,
                                       BoundedVector<Vec3f>& out) {
  VoxelDownsampleResult r;
  out.clear();
  r.input_points = static_cast<std::uint32_t>(points.size());
  if (!std::isfinite(voxel_size) || !(voxel_size > 0.0f)) {
    r.status = VoxelStatus::kInvalidVoxelSize;
    return r;
  }
  const std::size_t num_slots = slots.size();
  if (num_slots == 0 || (num_slots & (num_slots - 1)) != 0 || accumulators.empty()) {
    r.status = VoxelStatus::kInvalidStorage;
    return r;
  }
  const std::size_t max_voxels = std::min(out.capacity(), accumulators.size());

  // Pass 1: bounds of the finite points.
  double lo[3] = {INFINITY, INFINITY, INFINITY};
  for (const Vec3f& p : points) {
    if (!is_finite_point(p)) {
      ++r.non_finite_dropped;
      continue;
    }
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], static_cast<double>(p[d]));
  }
  if (r.non_finite_dropped == r.input_points) {
    r.status = VoxelStatus::kEmptyInput;
    return r;
  }
  const double voxel = voxel_size;
  const double origin[3] = {lo[0] - voxel * 0.5, lo[1] - voxel * 0.5, lo[2] - voxel * 0.5};

  // Pass 2: accumulate per voxel, voxels numbered in order of first occurrence.
  const auto max_probes = static_cast<std::uint32_t>(std::min(config::kVoxelMaxProbes, num_slots));
  std::size_t num_voxels = 0;
  VoxelAccumulator* last = nullptr;  // voxel of the previous accepted point
  std::int32_t last_ix = 0, last_iy = 0, last_iz = 0;
  for (const Vec3f& p : points) {
    if (!is_finite_point(p)) continue;
    double ref[3];
    bool in_range = true;
    for (int d = 0; d < 3; ++d) {
      ref[d] = std::floor((static_cast<double>(p[d]) - origin[d]) / voxel);
      in_range = in_range && ref[d] >= 0.0 && ref[d] <= kMaxVoxelIndex;
    }
    if (!in_range) {
      ++r.range_overflow;
      continue;
    }
    const auto ix = static_cast<std::int32_t>(ref[0]);
    const auto iy = static_cast<std::int32_t>(ref[1]);
    const auto iz = static_cast<std::int32_t>(ref[2]);
    // Consecutive returns of a scan usually fall in the same voxel: skip the table lookup.
    if (last != nullptr && ix == last_ix && iy == last_iy && iz == last_iz) {
      last->sum[0] += p.x();
      last->sum[1] += p.y();
      last->sum[2] += p.z();
      ++last->count;
      continue;
    }
    VoxelAccumulator* acc = nullptr;
    const ProbeResult probe = linear_probe(
        spatial_hash_folded(ix, iy, iz), num_slots, max_probes, [&](std::size_t s) {
          VoxelHashSlot& slot = slots[s];
          if (slot.voxel_plus_one == 0) {  // new voxel
            if (num_voxels == max_voxels) return true;  // output full: counted below
            slot = {ix, iy, iz, static_cast<std::uint32_t>(num_voxels + 1)};
            acc = &accumulators[num_voxels];
            *acc = {{0.0, 0.0, 0.0}, 0, static_cast<std::uint32_t>(s)};
            ++num_voxels;
            return true;
          }
          if (slot.ix == ix && slot.iy == iy && slot.iz == iz) {
            acc = &accumulators[slot.voxel_plus_one - 1];
            return true;
          }
          return false;
        });
    const bool no_slot = !probe.stopped;
    r.max_probe = std::max(r.max_probe, no_slot ? probe.probes : probe.probes + 1);
    if (acc == nullptr) {
      if (no_slot) {
        ++r.hash_overflow;
      } else {
        ++r.output_overflow;
      }
      continue;
    }
    acc->sum[0] += p.x();
    acc->sum[1] += p.y();
    acc->sum[2] += p.z();
    ++acc->count;
    last = acc;
    last_ix = ix;
    last_iy = iy;
    last_iz = iz;
  }

  // Centroids, and leave the hash table empty for the next call.
  for (std::size_t v = 0; v < num_voxels; ++v) {
    const VoxelAccumulator& acc = accumulators[v];
    const double n = static_cast<double>(acc.count);
    out.push_back(Vec3f(static_cast<float>(acc.sum[0] / n), static_cast<float>(acc.sum[1] / n),
                        static_cast<float>(acc.sum[2] / n)));
    slots[acc.slot] = VoxelHashSlot{};
  }
  r.output_points = static_cast<std::uint32_t>(out.size());
  const bool dropped = r.output_overflow + r.hash_overflow + r.range_overflow > 0;
  r.status = dropped ? VoxelStatus::kTruncated : VoxelStatus::kOk;
  return r;
}

}  // namespace v2xloc
