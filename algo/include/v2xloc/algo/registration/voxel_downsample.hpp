// Voxel-grid downsampling to voxel centroids, Open3D VoxelDownSample semantics (0.16):
//   min_bound   = component-wise minimum over the finite input points
//   voxel_min   = min_bound - voxel_size / 2
//   voxel index = floor((p - voxel_min) / voxel_size), computed in double
//   output      = per occupied voxel, the mean of its points (double sums, stored as float)
// Unlike Open3D (hash-map order) the output is in order of each voxel's first point in the input,
// so it is deterministic. Non-finite points are dropped and counted.
// Storage: a fixed open-addressing hash (power-of-two slots, linear probing bounded by
// config::kVoxelMaxProbes) and one accumulator per output voxel, both caller-owned. The slots
// must be all-zero (empty) on entry; the stage leaves them empty again, so a static, zero-
// initialised table is reused without clearing it (cost O(output), not O(slots)).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct VoxelHashSlot {
  std::int32_t ix = 0, iy = 0, iz = 0;
  std::uint32_t voxel_plus_one = 0;  // 0: empty; else output index + 1
};

struct VoxelAccumulator {
  double sum[3];
  std::uint32_t count;
  std::uint32_t slot;  // hash slot of this voxel (to empty it afterwards)
};

enum class VoxelStatus : std::uint8_t {
  kOk,
  kEmptyInput,         // no finite point
  kInvalidVoxelSize,   // voxel_size not finite or <= 0
  kInvalidStorage,     // slot count not a power of two, or no accumulator storage
  kTruncated,          // output, hash or index range overflowed: points dropped (see counters)
  kStoppedFull,        // stop_when_full: the output filled up; out is empty, output_overflow is 1
};

struct VoxelDownsampleResult {
  VoxelStatus status = VoxelStatus::kEmptyInput;
  std::uint32_t input_points = 0;
  std::uint32_t non_finite_dropped = 0;
  std::uint32_t output_points = 0;
  std::uint32_t output_overflow = 0;   // points of voxels that did not fit the output capacity
  std::uint32_t hash_overflow = 0;     // points whose voxel found no slot within kVoxelMaxProbes
  std::uint32_t range_overflow = 0;    // points whose voxel index does not fit int32
  std::uint32_t max_probe = 0;         // longest probe sequence seen
  std::uint32_t thinned = 0;           // points left out to keep to max_points (evenly spread)
};

// out is cleared first; its capacity bounds the number of voxels. accumulators needs
// out.capacity() entries (fewer -> that many voxels at most). A cloud of more than max_points
// points is downsampled from max_points of them evenly spread over it (the rest counted in thinned).
// stop_when_full: a caller that reads an overflowing cloud again coarser needs only to know that
// it overflows; the call ends at the first point whose voxel finds the output full (kStoppedFull).
VoxelDownsampleResult voxel_downsample(std::span<const Vec3f> points, float voxel_size,
                                       std::span<VoxelHashSlot> slots,
                                       std::span<VoxelAccumulator> accumulators,
                                       BoundedVector<Vec3f>& out, std::size_t max_points = SIZE_MAX,
                                       bool stop_when_full = false);

// Hash table and accumulators sized in the type. Large: declare it static.
template <std::size_t Slots = config::kVoxelHashSlots,
          std::size_t MaxVoxels = config::kMaxDownsampledPoints>
struct VoxelDownsampleStorage {
  static_assert((Slots & (Slots - 1)) == 0, "slot count must be a power of two");
  VoxelHashSlot slots[Slots]{};
  VoxelAccumulator accumulators[MaxVoxels];

  VoxelDownsampleResult run(std::span<const Vec3f> points, float voxel_size,
                            BoundedVector<Vec3f>& out, std::size_t max_points = SIZE_MAX,
                            bool stop_when_full = false) {
    return voxel_downsample(points, voxel_size, std::span<VoxelHashSlot>(slots, Slots),
                            std::span<VoxelAccumulator>(accumulators, MaxVoxels), out, max_points,
                            stop_when_full);
  }
};

}  // namespace v2xloc
