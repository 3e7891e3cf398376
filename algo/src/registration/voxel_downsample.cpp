#include "v2xloc/algo/registration/voxel_downsample.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc {
namespace {

bool finite3(const Vec3f& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

// Spatial hash of Teschner et al. 2003 (large primes, xor), on unsigned to avoid overflow UB.
std::uint32_t voxel_hash(std::int32_t x, std::int32_t y, std::int32_t z) {
  const std::uint32_t h = (static_cast<std::uint32_t>(x) * 73856093u) ^
                          (static_cast<std::uint32_t>(y) * 19349669u) ^
                          (static_cast<std::uint32_t>(z) * 83492791u);
  return h ^ (h >> 16);  // fold high bits in: the table index uses the low bits only
}

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
    if (!finite3(p)) {
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
  const std::size_t mask = num_slots - 1;
  std::size_t num_voxels = 0;
  VoxelAccumulator* last = nullptr;  // voxel of the previous accepted point
  std::int32_t last_ix = 0, last_iy = 0, last_iz = 0;
  for (const Vec3f& p : points) {
    if (!finite3(p)) continue;
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
    std::size_t s = voxel_hash(ix, iy, iz) & mask;
    std::uint32_t probes = 0;
    VoxelAccumulator* acc = nullptr;
    bool no_slot = true;
    for (; probes < config::kVoxelMaxProbes && probes < num_slots; ++probes, s = (s + 1) & mask) {
      VoxelHashSlot& slot = slots[s];
      if (slot.voxel_plus_one == 0) {  // new voxel
        no_slot = false;
        if (num_voxels == max_voxels) break;  // output full: counted below
        slot = {ix, iy, iz, static_cast<std::uint32_t>(num_voxels + 1)};
        acc = &accumulators[num_voxels];
        *acc = {{0.0, 0.0, 0.0}, 0, static_cast<std::uint32_t>(s)};
        ++num_voxels;
        break;
      }
      if (slot.ix == ix && slot.iy == iy && slot.iz == iz) {
        no_slot = false;
        acc = &accumulators[slot.voxel_plus_one - 1];
        break;
      }
    }
    r.max_probe = std::max(r.max_probe, no_slot ? probes : probes + 1);
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
