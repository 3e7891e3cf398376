// Reference map fused from infrastructure and agent LiDAR clouds (Chao et al. 2025, Fig. 1, "map
// fusion"): each source's cloud is transformed into the global frame by its sensor pose,
// voxel-downsampled and stored under the source's id and time stamp.
//   - a newer cloud from the same source replaces that source's points (sensors re-scan the
//     same scene; keeping both would double-count static structure and smear moving objects);
//   - clouds not newer than the stored one are stale (V2X reordering) and ignored;
//   - expire(t) evicts sources older than max_age (a parked agent's old view must not persist);
//   - at most config::kMaxMapSources sources; a new source takes a free slot or evicts the oldest
//     source if that one is older than the new cloud, otherwise it is refused (counted);
//   - consistency before trust (map_consistency.hpp, map_quorum.hpp): infrastructure units are
//     checked against each other where they overlap and fused by quorum; every unit's latest
//     cloud is stored, fused or not, so that it keeps its vote. Agents are checked against the
//     fused infrastructure and stored only when they agree. A cloud nobody can check is held back.
// extract() merges all sources on one voxel grid (centroids, deterministic order) for FPFH /
// registration; normals come from the shared normals stage (normals.hpp) over the extracted
// points: it needs the k-d tree the ICP target builds anyway, so the map does not duplicate it.
// Storage lives in the object (static storage only): ~12 MB host, ~1 MB EMBEDDED.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/map_consistency.hpp"
#include "v2xloc/algo/localization/map_fusion_params.hpp"
#include "v2xloc/algo/localization/map_quorum.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

enum class MapInsertStatus : std::uint8_t {
  kInserted,            // new source
  kReplaced,            // newer cloud of a known source
  kStale,               // not newer than the stored cloud
  kNoSourceSlot,        // kMaxMapSources newer sources present
  kRejectedInconsistent,  // disagrees with the fused infrastructure (agent) or the quorum (infra)
  kInvalidInput,        // non-finite pose or time
  kHeldBack,            // nothing could check it, or a disagreement nothing arbitrates: not fused
};

struct MapInsertResult {
  MapInsertStatus status = MapInsertStatus::kInvalidInput;
  std::uint32_t input_points = 0;
  std::uint32_t non_finite_dropped = 0;
  std::uint32_t stored_points = 0;      // after downsampling
  std::uint32_t capacity_dropped = 0;   // staging, downsampling or map capacity exceeded
  std::uint32_t covered_dropped = 0;    // agent points where the infrastructure already sees
  // Consistency: pairwise verdicts (an agent has one, against the fused infrastructure), and the
  // check with the most matched points (its offset is the candidate's estimated displacement).
  std::uint32_t agreeing = 0;
  std::uint32_t disagreeing = 0;
  std::uint32_t uncheckable = 0;
  MapCheckResult check;
};

struct MapSourceInfo {
  std::uint32_t id = 0;
  double timestamp = 0.0;               // [s] of the stored cloud
  Mat4d world_T_sensor = Mat4d::Identity();
  std::uint32_t points = 0;
  bool active = false;
  bool trusted = false;                 // surveyed infrastructure
  bool fused = false;                   // part of the extracted map (infrastructure: by quorum)
};

struct MapFusionCounters {
  std::uint64_t inserted = 0;
  std::uint64_t replaced = 0;
  std::uint64_t stale = 0;
  std::uint64_t no_source_slot = 0;
  std::uint64_t rejected_inconsistent = 0;  // clouds that disagree (offset or inliers), see status
  std::uint64_t held_back = 0;              // clouds not fused: uncheckable or unarbitrated
  std::uint64_t quorum_demoted = 0;         // stored units no longer fused after another's cloud
  std::uint64_t quorum_promoted = 0;        // stored units fused after another's cloud
  std::uint64_t check_cells_dropped = 0;    // candidate plane cells beyond the table (not checked)
  std::uint64_t sources_evicted_age = 0;
  std::uint64_t sources_evicted_slot = 0;   // oldest source displaced by a new one
  std::uint64_t points_dropped_capacity = 0;
  std::uint64_t non_finite_dropped = 0;
  std::uint64_t agent_points_covered = 0;   // agent points dropped where infrastructure sees
};

struct MapExtractResult {
  std::uint32_t points = 0;
  std::uint32_t capacity_dropped = 0;
};

class MapFusion {
 public:
  explicit MapFusion(const MapFusionParams& params = {});
  MapFusion(const MapFusion&) = delete;
  MapFusion& operator=(const MapFusion&) = delete;
  void configure(const MapFusionParams& params) {
    params_ = params;
    counters_ = {};
    clear();
  }
  void clear();

  // points in the sensor frame; world_T_sensor maps them into the global frame. trusted: a
  // surveyed infrastructure unit (voted on by the quorum), else an agent (checked against the
  // fused infrastructure).
  MapInsertResult insert(std::uint32_t source_id, double timestamp, const Mat4d& world_T_sensor,
                         std::span<const Vec3f> points, bool trusted = false);
  // Evicts sources with now - timestamp > max_age; returns how many.
  std::uint32_t expire(double now);
  // Merged map of the fused sources on the voxel grid into `out` (cleared first).
  MapExtractResult extract(BoundedVector<Vec3f>& out);

  std::size_t point_count() const { return num_points_; }  // stored, fused or not
  std::uint64_t revision() const { return revision_; }  // changes whenever the map changes
  std::span<const MapSourceInfo> sources() const { return {sources_, config::kMaxMapSources}; }
  const MapFusionCounters& counters() const { return counters_; }
  const MapFusionParams& params() const { return params_; }

 private:
  struct Cell {
    std::int32_t key[3];
    std::uint32_t stamp;  // occupied iff stamp == stamp_ (no clearing between uses)
  };
  static constexpr std::size_t kSlots = config::kMapFusionHashSlots;
  static_assert((kSlots & (kSlots - 1)) == 0, "hash slots must be a power of two");
  static_assert(config::kMaxMapSources <= 255, "source slot stored in a byte");

  // insert() steps, in order.
  std::size_t find_slot(std::uint32_t source_id, double timestamp, bool trusted, MapInsertResult& r,
                        bool& displace);
  void stage_cloud(const Mat4d& world_T_sensor, std::span<const Vec3f> points, MapInsertResult& r);
  void check_infrastructure(std::size_t slot, MapInsertResult& r);
  void check_agent(MapInsertResult& r);
  void store(std::size_t slot, bool replaced, std::uint32_t source_id, double timestamp,
             const Mat4d& world_T_sensor, bool trusted, MapInsertResult& r);
  // Re-decides which infrastructure units are fused; returns the standing of `slot`.
  QuorumStanding arbitrate(std::size_t slot);

  void remove_source_points(std::size_t slot);
  void release_slot(std::size_t slot);
  std::span<const Vec3f> source_points(std::size_t slot) const {
    return {points_ + first_point_[slot], sources_[slot].points};
  }
  void fold_check(const MapCheckResult& c, MapInsertResult& r) const;
  bool cell_key(const Vec3f& p, double cell, std::int32_t key[3]) const;
  void new_cell_generation();  // empties the cell table (O(1) except on stamp wrap-around)
  bool mark(const std::int32_t key[3]);
  bool occupied(const std::int32_t key[3]) const;
  bool occupied_around(const Vec3f& p, double cell) const;
  // Drops candidate points near a fused infrastructure point (agent_fill_cell); returns how many.
  std::uint32_t drop_covered_by_trusted();

  MapFusionParams params_;
  MapSourceInfo sources_[config::kMaxMapSources];
  Vec3f points_[config::kMaxMapPoints];
  std::uint8_t point_source_[config::kMaxMapPoints];
  std::size_t first_point_[config::kMaxMapSources] = {};  // each source's points are contiguous
  std::size_t num_points_ = 0;
  std::uint64_t revision_ = 0;
  MapFusionCounters counters_;

  FixedVector<Vec3f, config::kMaxScanPoints> staging_;
  FixedVector<Vec3f, config::kMaxMapPoints> candidate_;
  VoxelDownsampleStorage<config::kMapFusionHashSlots, config::kMaxMapPoints> downsample_;
  MapConsistencyCheck check_;
  InfraQuorum quorum_;
  Cell cells_[kSlots] = {};
  std::uint32_t stamp_ = 0;
};

}  // namespace v2xloc
