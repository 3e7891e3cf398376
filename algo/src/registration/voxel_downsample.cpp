#include "v2xloc/algo/registration/voxel_downsample.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/even_thinning.hpp"
#include "v2xloc/algo/core/finite.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"
#include "v2xloc/algo/core/unroll.hpp"

namespace v2xloc {
namespace {

constexpr double kMaxVoxelIndex = 2147483520.0;  // < 2^31, exactly representable

struct VoxelIndex {
  std::int32_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelIndex&) const = default;
};

// The points a call uses: all of them, or `take` of them evenly spread over the cloud
// (even_thinning.hpp), so a cloud over the limit keeps its whole extent at a lower density
// instead of losing its tail (for a scan, the sweep's last sectors).
class EvenSelection {
 public:
  EvenSelection(std::size_t n, std::size_t take) : n_(n), take_(take < n ? take : n) {}
  bool all() const { return take_ == n_; }
  bool kept(std::size_t i) const { return all() || kept_evenly(i, n_, take_); }
  std::size_t skipped() const { return n_ - take_; }

 private:
  std::uint64_t n_, take_;
};

// Component-wise minimum of the finite points into lo; the others are counted.
void finite_min_bound(std::span<const Vec3f> points, const EvenSelection& selection, double lo[3],
                      std::uint32_t& non_finite) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!selection.kept(i)) continue;
    const Vec3f& p = points[i];
    if (!is_finite_point(p)) {
      ++non_finite;
      continue;
    }
    V2XLOC_UNROLL_AXES for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], static_cast<double>(p[d]));
  }
}

// floor((p - origin) / voxel) per axis in double; false when an index does not fit int32 (0 to
// kMaxVoxelIndex). floor(q) is in that range exactly when 0 <= q < kMaxVoxelIndex + 1 (NaN fails),
// and there truncation is the floor: no libm call.
bool voxel_index_of(const Vec3f& p, const double origin[3], double voxel, VoxelIndex& index) {
  double q[3];
  bool in_range = true;
  V2XLOC_UNROLL_AXES for (int d = 0; d < 3; ++d) {
    q[d] = (static_cast<double>(p[d]) - origin[d]) / voxel;
    in_range = in_range && q[d] >= 0.0 && q[d] < kMaxVoxelIndex + 1.0;
  }
  if (!in_range) return false;
  index = {static_cast<std::int32_t>(q[0]), static_cast<std::int32_t>(q[1]), static_cast<std::int32_t>(q[2])};
  return true;
}

void add_point(VoxelAccumulator& acc, const Vec3f& p) {
  acc.sum[0] += p.x();
  acc.sum[1] += p.y();
  acc.sum[2] += p.z();
  ++acc.count;
}

// The caller's hash table and accumulators for one call: voxels are numbered in order of first
// occurrence, at most max_voxels of them.
class VoxelTable {
 public:
  VoxelTable(std::span<VoxelHashSlot> slots, std::span<VoxelAccumulator> accumulators,
             std::size_t max_voxels)
      : slots_(slots),
        accumulators_(accumulators),
        max_voxels_(max_voxels),
        max_probes_(static_cast<std::uint32_t>(std::min(config::kVoxelMaxProbes, slots.size()))) {}

  // The accumulator of voxel `index`, created on first sight; nullptr when no slot is found
  // within the probe bound or the output is full (counted in r, as is the probe length).
  VoxelAccumulator* find_or_add(const VoxelIndex& index, VoxelDownsampleResult& r) {
    VoxelAccumulator* acc = nullptr;
    const ProbeResult probe = linear_probe(
        spatial_hash_folded(index.x, index.y, index.z), slots_.size(), max_probes_, [&](std::size_t s) {
          VoxelHashSlot& slot = slots_[s];
          if (slot.voxel_plus_one == 0) {  // new voxel
            if (num_voxels_ == max_voxels_) return true;  // output full: counted below
            slot = {index.x, index.y, index.z, static_cast<std::uint32_t>(num_voxels_ + 1)};
            acc = &accumulators_[num_voxels_];
            *acc = {{0.0, 0.0, 0.0}, 0, static_cast<std::uint32_t>(s)};
            ++num_voxels_;
            return true;
          }
          if (slot.ix == index.x && slot.iy == index.y && slot.iz == index.z) {
            acc = &accumulators_[slot.voxel_plus_one - 1];
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
    }
    return acc;
  }

  // The slots emptied for the next call, no centroid written (a pass stopped when full).
  void clear() {
    for (std::size_t v = 0; v < num_voxels_; ++v) slots_[accumulators_[v].slot] = VoxelHashSlot{};
    num_voxels_ = 0;
  }

  // Centroids into out, and the slots emptied for the next call.
  void write_centroids(BoundedVector<Vec3f>& out) {
    for (std::size_t v = 0; v < num_voxels_; ++v) {
      const VoxelAccumulator& acc = accumulators_[v];
      const double n = static_cast<double>(acc.count);
      out.push_back(Vec3f(static_cast<float>(acc.sum[0] / n), static_cast<float>(acc.sum[1] / n),
                          static_cast<float>(acc.sum[2] / n)));
      slots_[acc.slot] = VoxelHashSlot{};
    }
  }

 private:
  std::span<VoxelHashSlot> slots_;
  std::span<VoxelAccumulator> accumulators_;
  std::size_t max_voxels_;
  std::uint32_t max_probes_;
  std::size_t num_voxels_ = 0;
};

// Every finite point into the accumulator of its voxel (range overflows counted in r);
// stop_when_full: ends at the first point whose voxel finds the output full (false returned).
bool accumulate_points(std::span<const Vec3f> points, const EvenSelection& selection, const double origin[3],
                       double voxel, bool stop_when_full, VoxelTable& table, VoxelDownsampleResult& r) {
  VoxelAccumulator* last = nullptr;  // voxel of the previous accepted point
  VoxelIndex last_index;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (!selection.kept(i) || !is_finite_point(p)) continue;
    VoxelIndex index;
    if (!voxel_index_of(p, origin, voxel, index)) {
      ++r.range_overflow;
      continue;
    }
    // Consecutive returns of a scan usually fall in the same voxel: skip the table lookup.
    VoxelAccumulator* acc = last != nullptr && index == last_index ? last : table.find_or_add(index, r);
    if (acc == nullptr) {
      if (stop_when_full && r.output_overflow > 0) return false;
      continue;
    }
    add_point(*acc, p);
    last = acc;
    last_index = index;
  }
  return true;
}

}  // namespace

VoxelDownsampleResult voxel_downsample(std::span<const Vec3f> points, float voxel_size,
                                       std::span<VoxelHashSlot> slots,
                                       std::span<VoxelAccumulator> accumulators,
                                       BoundedVector<Vec3f>& out, std::size_t max_points,
                                       bool stop_when_full) {
  VoxelDownsampleResult r;
  out.clear();
  r.input_points = static_cast<std::uint32_t>(points.size());
  const EvenSelection selection(points.size(), max_points);
  r.thinned = static_cast<std::uint32_t>(selection.skipped());
  if (!std::isfinite(voxel_size) || !(voxel_size > 0.0f)) {
    r.status = VoxelStatus::kInvalidVoxelSize;
    return r;
  }
  const std::size_t num_slots = slots.size();
  if (num_slots == 0 || (num_slots & (num_slots - 1)) != 0 || accumulators.empty()) {
    r.status = VoxelStatus::kInvalidStorage;
    return r;
  }

  // Pass 1: bounds of the finite points.
  double lo[3] = {INFINITY, INFINITY, INFINITY};
  finite_min_bound(points, selection, lo, r.non_finite_dropped);
  if (r.non_finite_dropped == r.input_points - r.thinned) {
    r.status = VoxelStatus::kEmptyInput;
    return r;
  }
  const double voxel = voxel_size;
  const double origin[3] = {lo[0] - voxel * 0.5, lo[1] - voxel * 0.5, lo[2] - voxel * 0.5};

  // Pass 2: accumulate per voxel; then centroids, leaving the hash table empty for the next call.
  VoxelTable table(slots, accumulators, std::min(out.capacity(), accumulators.size()));
  if (!accumulate_points(points, selection, origin, voxel, stop_when_full, table, r)) {
    table.clear();  // out stays empty: the caller reads the cloud again coarser
    r.status = VoxelStatus::kStoppedFull;
    return r;
  }
  table.write_centroids(out);
  r.output_points = static_cast<std::uint32_t>(out.size());
  const bool dropped = r.output_overflow + r.hash_overflow + r.range_overflow > 0;
  r.status = dropped ? VoxelStatus::kTruncated : VoxelStatus::kOk;
  return r;
}

}  // namespace v2xloc
