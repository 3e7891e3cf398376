// The LiDAR odometry's local map (KISS-ICP, Vizzo et al. 2023, Sec. III-D/E): world points in
// cubic voxels of edge v, at most max_points_per_voxel each, a voxel hash over integer keys
// (core/spatial_hash.hpp), and the nearest-neighbour query the ICP runs ~1e4 times a frame.
// Points of voxel i are contiguous, in insertion order (the query's tie-break: first point wins).
// Per voxel the bounding box of its points is kept: a query skips the voxel's points when the box
// is already farther than the best match (exact: distances are monotone in each coordinate gap).
// The index is rebuilt only in frames that evict a voxel (voxel indices change only then).
// Storage: points double-buffered for compaction (runs of unchanged voxels are copied with one
// memcpy), voxels compacted in place; static storage only (no heap).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <type_traits>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

// A map point: plain floats, so compaction copies whole runs of them with memcpy.
struct MapPoint {
  float x, y, z;
};

class OdometryVoxelMap {
 public:
  // Voxel indices fit 16 bits when the map's capacity does (EMBEDDED): a smaller cache below.
  using BlockVoxel = std::conditional_t<(config::kOdometryMapPoints <= 0xFFFFu), std::uint16_t, std::uint32_t>;
  // A query's 2 x 2 x 2 voxel block, remembered between queries of one source point while the
  // map is unchanged (the odometry's ICP iterations move a point by millimetres): a query whose
  // block and own voxel are the remembered ones scans the block's non-empty voxels from the list
  // instead of hashing eight keys again (most of a block's voxels are empty).
  struct NeighborBlock {
    std::int32_t lo[3];        // the block's lowest key; kNoBlock in lo[0]: nothing remembered
    std::uint8_t own;          // the query's own voxel's offset from lo (x 1, y 2, z 4)
    std::uint8_t count;        // non-empty voxels of the block
    std::uint8_t rank[8];      // their places in the search order (own voxel, faces, edges, corner)
    BlockVoxel voxel[8];       // their indices, in that order
  };
  static constexpr std::int32_t kNoBlock = std::numeric_limits<std::int32_t>::min();  // no key: |key| < 2^30

  OdometryVoxelMap() = default;
  OdometryVoxelMap(const OdometryVoxelMap&) = delete;
  OdometryVoxelMap& operator=(const OdometryVoxelMap&) = delete;

  // New voxel edge [m] and per-voxel cap (clamped to [1, kOdometryMaxPointsPerVoxel]); clears.
  void configure(double voxel_size, std::uint32_t max_points_per_voxel);
  void clear();
  // The nearest map point to p with squared distance < max_d2 among the 2 x 2 x 2 voxels around
  // p (see odometry_map.cpp); false when there is none.
  bool nearest(const Vec3d& p, double max_d2, Vec3d& q, double& d2) const;
  // The same result, remembering the block in `block` (set lo[0] = kNoBlock before the first
  // query and after every update()).
  bool nearest(const Vec3d& p, double max_d2, Vec3d& q, double& d2, NeighborBlock& block) const;
  // Adds frame (sensor frame) moved by pose, in order, up to the per-voxel and total caps, then
  // drops voxels whose centre lies beyond max_range of the sensor. Points that found no room
  // (total cap, hash probes, key range) are added to dropped; evicted voxels to evicted.
  void update(std::span<const Vec3f> frame, const Mat4d& pose, double max_range, std::uint32_t& dropped,
              std::uint32_t& evicted);

  std::span<const MapPoint> points() const { return {map_[active_], num_points_}; }
  std::size_t voxel_count() const { return num_voxels_; }
  // floor(p / v) per axis; false outside |key| < 2^30.
  bool voxel_key(const Vec3d& p, std::int32_t key[3]) const;
  // Points of the voxel with this key (empty if there is none), in insertion order.
  std::span<const MapPoint> voxel_points(const std::int32_t key[3]) const;

 private:
  struct Voxel {
    std::int32_t key[3];
    std::uint32_t begin;
    std::uint32_t count;
    std::uint32_t pending;  // points to append this frame
    std::uint32_t slot;     // hash slot
    float lo[3];            // bounding box of the points
    float hi[3];
  };
  static constexpr std::size_t kMaxPoints = config::kOdometryMapPoints;
  static constexpr std::size_t kSlots = config::kOdometryHashSlots;
  static_assert((kSlots & (kSlots - 1)) == 0, "hash slots must be a power of two");
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  static_assert(kMaxPoints <= std::numeric_limits<BlockVoxel>::max(), "voxel index fits NeighborBlock");

  bool voxel_key(const Vec3d& p, std::int32_t key[3], double quotient[3]) const;
  void fill_block(const std::int32_t lo[3], int own, NeighborBlock& block) const;
  std::uint32_t find_voxel(const std::int32_t key[3]) const;  // index or kNone
  std::uint32_t insert_voxel(const std::int32_t key[3]);      // index or kNone (full)
  void scan_voxel(const Voxel& vx, const Vec3d& p, double& d2, const MapPoint*& best) const;
  struct Run {  // map_[active_][from, + count) -> map_[next][to, + count)
    std::uint32_t from = 0, to = 0, count = 0;
  };
  void copy_run(const Run& run, int next);
  void rebuild_index();

  double voxel_size_ = 1.0;
  std::uint32_t max_per_voxel_ = 20;
  MapPoint map_[2][kMaxPoints];
  Voxel voxels_[kMaxPoints];         // compacted in place
  std::uint32_t remap_[kMaxPoints];  // update(): old voxel index -> new (kNone: evicted)
  std::uint32_t slots_[kSlots] = {};  // voxel index + 1, 0 = empty
  int active_ = 0;
  std::size_t num_points_ = 0;
  std::size_t num_voxels_ = 0;
  std::uint32_t frame_voxel_[config::kMaxDownsampledPoints];  // update(): voxel per frame point
};

}  // namespace v2xloc
