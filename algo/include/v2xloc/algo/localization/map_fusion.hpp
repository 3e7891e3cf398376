// Reference map fused from infrastructure and agent LiDAR clouds (Chao et al. 2025, Fig. 1, "map
// fusion"): each source's cloud is transformed into the global frame by its sensor pose,
// voxel-downsampled and stored under the source's id and time stamp.
//   - a newer cloud from the same source replaces that source's points (sensors re-scan the
//     same scene; keeping both would double-count static structure and smear moving objects);
//   - clouds not newer than the stored one are stale (V2X reordering) and ignored;
//   - expire(t) evicts sources older than max_age (a parked agent's old view must not persist);
//   - at most config::kMaxMapSources sources; a new source takes a free slot or evicts the oldest
//     source if that one is older than the new cloud, otherwise it is refused (counted);
//   - a cloud that does not fit the map's free room gets a share of it: capacity / active
//     sources. Sources above the share are thinned to it and the cloud to what is free, evenly
//     along their order (deterministic; counted). Appending until full kept the first source
//     whole and gave later units nothing (EMBEDDED: one 0.2 m infrastructure cloud alone filled
//     the 8,192-point map). Evenly, not the points nearest the sensor: those are mostly ground
//     and registration on them failed on every recording. No effect while clouds fit (the host
//     profile's capacities);
//   - surveyed background: an infrastructure unit with one (set_background, surveyed_background.hpp)
//     has each cloud checked against it first, in its sensor frame; a cloud off its background is
//     rejected (kBackgroundMismatch, counted) whatever the other units say. Units without one are
//     handled as before;
//   - consistency hook: before a cloud is accepted, its overlap with the other sources is measured
//     (fraction of its points with another source's point nearby, over the points in the region
//     the others cover); a source below min_fitness with enough overlap is rejected and counted
//     (a mis-calibrated, spoofed or malicious sender). The surveyed sources' cells are kept
//     between inserts (source_cells.hpp), so a check only looks cells up.
// extract() merges all sources on one voxel grid (centroids, deterministic order) for FPFH /
// registration; normals come from the shared normals stage (normals.hpp) over the extracted
// points: it needs the k-d tree the ICP target builds anyway, so the map does not duplicate it.
// Storage lives in the object (static storage only): ~17 MB host, ~1.9 MB EMBEDDED (v2xloc-info).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"
#include "v2xloc/algo/localization/source_cells.hpp"
#include "v2xloc/algo/localization/surveyed_background.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

struct MapFusionParams {
  double voxel_size = 0.2;          // [m] map resolution (registration voxel size)
  double max_age = 4.0;             // [s] sources older than this are evicted by expire() (paced: a stored cloud is up to ~2 s older than its source's latest)
  bool check_consistency = true;
  double inlier_distance = 0.3;     // [m] "another source's point nearby" (~1.5 voxels)
  double overlap_cell = 2.0;        // [m] cells that define the region the other sources cover
  std::uint32_t min_overlap_points = 50;  // fewer overlapping points: no verdict, accepted
  // Inlier ratio over the overlap region below which a cloud is rejected. A consistent source
  // scores > 0.95 (test: 0.99); a 1.5 m / 5 deg pose error still scores ~0.5 on planar scenes
  // (points slide along walls and ground), so the bar sits between.
  double min_fitness = 0.7;
  // Agents fill gaps only: an agent's points within ~agent_fill_cell of a trusted (surveyed
  // infrastructure) point are dropped. Agents place their clouds by their own localization
  // (cm bias, tenths of a degree); where the infrastructure already sees a surface, the agent's
  // copy only blurs and biases it. 0 keeps every agent point.
  double agent_fill_cell = 0.5;  // [m]
  // Shift probe: the cloud is also scored displaced by +-probe_step (and +-2 probe_step on each
  // horizontal axis); if it fits the others better anywhere but where its sender put it, by more
  // than probe_margin, its pose is wrong (a rogue or mis-calibrated source) and it is rejected.
  // A consistent cloud peaks at zero offset (test scene: 1.000 there, 0.967 at the best probe);
  // shifted 0.25 m it scores 0.966 where the probe that undoes the shift scores 1.000, so the
  // margin must sit below that 0.034 gap.
  double probe_step = 0.25;      // [m]
  double probe_margin = 0.02;    // fitness difference, agents
  // Infrastructure units are checked against each other, in arrival order: a rogue unit that
  // arrives first becomes part of the reference, and a tight margin then rejects the genuine
  // units instead (measured: 0.25 m rogue, margin 0.02 -> fused error 4.1 m). 0.1 never inverted in
  // the runs. It applies against one other unit only; with more, the quorum below (and units
  // accepted before it existed are vetted once it does, so arrival order does not decide).
  double infra_probe_margin = 0.1;  // fitness difference, infrastructure against one other unit
  // Quorum: the more other units the reference holds, the sharper an exact unit's score. Measured on
  // the four Sim scenes (4_infra, t = 0 and 5 s, each unit against every subset of the others, shifts
  // of 0.25-10 m along x and y): against two others an exact unit peaks at zero offset (fitness minus
  // best probe 0.012..0.097) while one shifted 0.25 or 0.5 m does not (<= -0.016); against three
  // others an exact unit scores >= 0.563 and one shifted >= 0.5 m <= 0.471 (and 1-10 m shifts, whose
  // probe profile is flat, are caught only by that floor). Against one other unit the ranges overlap
  // (exact 0.17-0.40, shifted 0.06-0.37): two units cannot outvote each other, the survey
  // (firmware trust list) is their only check, and the loose margin above stays.
  double infra_quorum_margin = 0.0;     // probe margin with >= 2 other units in the reference
  double infra_quorum_min_fitness = 0.5;  // fitness floor with >= 3 other units in the reference
  std::uint32_t max_probe_points = 1024;  // overlap points scored per probe (even stride)
  // Candidate points the consistency check scores (even stride; clamped to
  // config::kMapConsistencyPoints): a fitness is a fraction, 2k samples pin it to ~1 % (the
  // 0.02 probe margin is ~4 sigma of a 1k-point probe at fitness 0.97), and a full pass cost
  // ~80 M instructions per 30k-point infrastructure cloud. Halving 4096 / 2048 changed no verdict
  // on the 12 recordings (fused trajectories byte-identical). 0: the cap.
  std::uint32_t max_consistency_points = 2048;
  // Sources per role: invented agent ids cannot evict surveyed infrastructure, nor the reverse.
  std::uint32_t max_trusted_sources = config::kMaxMapSources / 2;
  std::uint32_t max_agent_sources = config::kMaxMapSources / 2;
  // Map points held (the shares divide this); 0 or more than config::kMaxMapPoints: that capacity.
  std::uint32_t max_points = 0;
  // A cloud with more voxels than the candidate holds (config::kMaxMapPoints) would be cut in
  // scan order, dropping whole sectors; it is downsampled again with the voxel doubled, at most
  // this many times (then cut, counted). EMBEDDED: a 16k-point infrastructure cloud has ~12.6k
  // voxels at 0.2 m, ~9.2k at 0.4 m, ~4.9k at 0.8 m. Never needed with the host capacities.
  std::uint32_t max_coarsen_steps = 3;
  // [points] a cloud with more points is read with an even stride down to this many before it is
  // staged (counted): sources share max_points, so a source keeps a few thousand of them anyway,
  // and staging, downsampling and marking a 131k-point cloud cost ~160 M instructions, over a
  // whole period's budget. The recordings' clouds hold <= 16.2k points. At most the staging's
  // capacity (config::kMaxMapInputPoints); 0: no stride, a cloud over that capacity is cut there
  // (counted).
  std::uint32_t max_input_points = 16384;
  // Infrastructure clouds of a unit with a surveyed background are checked against it (thresholds:
  // surveyed_background.hpp, measured in algo/TUNING.md); false skips that check.
  bool check_background = true;
  BackgroundCheckParams background{};
};

enum class MapInsertStatus : std::uint8_t {
  kInserted,            // new source
  kReplaced,            // newer cloud of a known source
  kStale,               // not newer than the stored cloud
  kNoSourceSlot,        // kMaxMapSources newer sources present
  kRejectedInconsistent,
  kInvalidInput,        // non-finite pose or time
  kHeldBack,            // too little overlap to be checked: an agent, or infrastructure facing a quorum
  kPaced,               // within map.cloud_interval of the source's stored cloud: not needed (reference_map.hpp)
  kBackgroundMismatch,  // infrastructure cloud off its unit's surveyed background
};

struct MapInsertResult {
  MapInsertStatus status = MapInsertStatus::kInvalidInput;
  std::uint32_t input_points = 0;
  std::uint32_t non_finite_dropped = 0;
  std::uint32_t stored_points = 0;      // after downsampling
  std::uint32_t capacity_dropped = 0;   // staging, downsampling or map capacity exceeded
  std::uint32_t overlap_points = 0;     // consistency check: points in the others' region
  std::uint32_t covered_dropped = 0;    // agent points where the infrastructure already sees
  double consistency_fitness = 1.0;     // inliers / overlap_points (1 when no verdict)
  double best_probe_fitness = 0.0;      // best fitness of the shifted probes (shift check)
  bool outvoted = false;                // infrastructure rejected or held back by the quorum: its stored cloud evicted too
  bool quorum_checked = false;          // infrastructure checked by the full rule (>= 3 other units)
  std::uint32_t share_trimmed = 0;      // other sources' points thinned to the share to make room
  std::uint32_t coarsened = 0;          // voxel doublings to fit the candidate (max_coarsen_steps)
  std::uint32_t input_thinned = 0;      // input points skipped by the max_input_points stride
  std::uint32_t units_vetted = 0;       // other infrastructure units checked by the quorum after this insert
  bool cells_rebuilt = false;           // the reference cells were rebuilt from every surveyed source
  bool background_checked = false;      // scored against the unit's surveyed background
  BackgroundScore background{};         // that score (zero offset, best probe, points)
};

struct MapSourceInfo {
  std::uint32_t id = 0;
  double timestamp = 0.0;               // [s] of the stored cloud
  Pose3d world_T_sensor = Pose3d::Identity();
  std::uint32_t points = 0;
  bool active = false;
  bool trusted = false;                 // surveyed infrastructure
  bool vetted = false;                  // infrastructure: its stored cloud passed the full quorum rule
};

struct MapFusionCounters {
  std::uint64_t inserted = 0;
  std::uint64_t replaced = 0;
  std::uint64_t stale = 0;
  std::uint64_t no_source_slot = 0;
  std::uint64_t rejected_inconsistent = 0;  // low fitness or fits better shifted
  std::uint64_t infra_outvoted = 0;         // of those: infrastructure rejected by the quorum rule
  std::uint64_t infra_evicted = 0;          // outvoted units' stored clouds removed with them
  std::uint64_t held_back = 0;              // clouds that could not be checked (agents, infrastructure)
  std::uint64_t infra_unchecked = 0;        // of those: infrastructure with >= 2 other units present
  std::uint64_t sources_evicted_age = 0;
  std::uint64_t sources_evicted_slot = 0;   // oldest source displaced by a new one
  std::uint64_t points_dropped_capacity = 0;
  std::uint64_t points_trimmed_share = 0;   // stored points thinned to make room for a new cloud's share
  std::uint64_t clouds_coarsened = 0;       // clouds downsampled again with a coarser voxel
  std::uint64_t input_points_thinned = 0;   // input points skipped by the max_input_points stride
  std::uint64_t non_finite_dropped = 0;
  std::uint64_t agent_points_covered = 0;   // agent points dropped where infrastructure sees
  std::uint64_t reference_cells_dropped = 0;  // reference cells not recorded (hash probes exhausted)
  std::uint64_t background_checked = 0;     // infrastructure clouds scored against their surveyed background
  std::uint64_t background_mismatch = 0;    // of those: rejected, off the background
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
  // Resets the sources, counters and surveyed backgrounds: set backgrounds after configure().
  void configure(const MapFusionParams& params) {
    params_ = params;
    counters_ = {};
    for (BackgroundSlot& b : backgrounds_) b = BackgroundSlot{};
    clear();
  }
  void clear();

  // points in the sensor frame; world_T_sensor maps them into the global frame. A trusted source
  // (surveyed infrastructure) is checked against the other infrastructure units only: sensors at
  // different corners see different faces of the same buildings, so one pair's overlap score is
  // low (0.2-0.4 for exact poses) and only the shift probe applies; two or three other units
  // form the quorum (infra_quorum_*) that can outvote it and evict its stored cloud.
  // background_fits: fits_background(source_id, world_T_sensor, points) was true for exactly
  // these points (the firmware's share filter asked before the signature check): not scored again.
  MapInsertResult insert(std::uint32_t source_id, double timestamp, const Pose3d& world_T_sensor,
                         std::span<const Vec3f> points, bool trusted = false, bool background_fits = false);
  // The surveyed background of infrastructure unit source_id (its cells stay the caller's and must
  // outlive this object's use of them; a second call replaces the unit's). False, nothing kept:
  // not background_valid, or config::kMaxBackgroundUnits other units have one.
  bool set_background(std::uint32_t source_id, const SurveyedBackground& background);
  // The unit's background, else null.
  const SurveyedBackground* background(std::uint32_t source_id) const;
  // The background verdict insert() would give an infrastructure cloud of source_id, without
  // inserting or counting: true when the unit has no background or the check is off. Lets a caller
  // refuse a share off its background before paying for its signature check.
  bool fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor, std::span<const Vec3f> points) const;
  // Evicts sources with now - timestamp > max_age; returns how many.
  std::uint32_t expire(double now);
  // Merged map on the voxel grid into `out` (cleared first).
  MapExtractResult extract(BoundedVector<Vec3f>& out);

  std::size_t point_count() const { return num_points_; }
  std::uint64_t revision() const { return revision_; }  // changes whenever the map changes
  std::span<const MapSourceInfo> sources() const { return {sources_, config::kMaxMapSources}; }
  const MapFusionCounters& counters() const { return counters_; }
  const MapFusionParams& params() const { return params_; }

 private:
  // Grids of the consistency reference (SourceCells levels): inlier cells, overlap region, agent fill.
  enum CellLevel : std::int32_t { kInlierLevel = 0, kOverlapLevel = 1, kFillLevel = 2 };
  static_assert(config::kMaxMapSources <= 255, "source slot stored in a byte");

  struct BackgroundSlot {
    std::uint32_t id = 0;
    bool used = false;
    SurveyedBackground background{};
  };

  // A cloud's score on a background, in its sensor frame (no counting).
  BackgroundScore score_on_background(const SurveyedBackground& background, const Mat4d& world_T_sensor,
                                      std::span<const Vec3f> points) const;
  // The background verdict on a trusted cloud (r filled; false: rejected and counted).
  bool passes_background(const SurveyedBackground& background, const Mat4d& world_T_sensor,
                         std::span<const Vec3f> points, bool known_to_fit, MapInsertResult& r);
  void remove_source_points(std::size_t slot);
  // Point `from` (with its source and cell slots) to index `to` <= from: stable compaction.
  void move_point(std::size_t from, std::size_t to);
  // Sets the source's bit in the reference cells of its stored points from index `first` on (a
  // stored cloud is appended at the end) and records each point's cell slots; surveyed sources
  // only: the reference is the infrastructure.
  void mark_source_cells(std::size_t slot, std::size_t first);
  // The same for every source in `sources` at once (one pass over the map).
  void mark_cells(SourceCells::Mask sources, std::size_t first);
  // Clears the source's bit through the recorded slots (no keys recomputed).
  void clear_source_cells(std::size_t slot);
  // Sets (or clears) the bits of every source in `sources` through their points' recorded slots.
  void set_recorded_cells(SourceCells::Mask sources, bool set);
  bool rebuild_cells_if_crowded();  // true when it rebuilt
  // Bits of the active surveyed sources other than `slot` (config::kMaxMapSources: all of them): the
  // reference a cloud is checked against.
  SourceCells::Mask trusted_bits(std::size_t slot) const;
  // Fraction of candidate points near other sources' points (see header), excluding `slot`;
  // only trusted (infrastructure) sources are the reference. best_probe: the best fitness of the
  // candidate displaced by the shift probes; a probe stops once it cannot beat the cloud's own
  // fitness by `margin` (the verdict needs no more), so best_probe is exact when it beats it and a
  // lower bound otherwise. No probes run when the overlap is below min_overlap_points.
  double consistency(std::size_t slot, double margin, std::uint32_t& overlap_points, double& best_probe);
  // Infrastructure accepted before the full quorum existed (the first units to send) is checked once
  // three other units are present: each unvetted stored cloud against the others, evicted if outvoted.
  std::uint32_t vet_infrastructure();
  void evict_outvoted(std::size_t slot);
  // Active trusted sources other than `slot` (the units an infrastructure cloud is checked against).
  std::uint32_t other_trusted(std::size_t slot) const;
  // Drops candidate points near a trusted source's point (agent_fill_cell); returns how many.
  std::uint32_t drop_covered_by_trusted(std::size_t slot);
  // Slot of the active source with this id, else kMaxMapSources.
  std::size_t find_source(std::uint32_t source_id) const;
  // Slot for a new source: a free one, else the oldest of its role if older than timestamp
  // (displace set), else kMaxMapSources.
  std::size_t claim_source_slot(bool trusted, double timestamp, bool& displace) const;
  // The cloud in the global frame, downsampled into candidate_ (drops counted in r), from
  // coarsening step first_step on (the voxel doubled that many times).
  void stage_candidate(const Mat4d& world_T_sensor, std::span<const Vec3f> points, std::uint32_t first_step,
                       MapInsertResult& r);
  // Consistency verdict on candidate_ against the other sources; false (status and counter
  // set in r) when the cloud is held back or rejected.
  bool passes_consistency(std::size_t own_slot, bool trusted, MapInsertResult& r);
  // Appends candidate_ under `slot` up to the map capacity (overflow counted in r), and a
  // surveyed source's points to the reference cells; returns how many. When it does not fit,
  // make_room() first.
  std::uint32_t store_candidate(std::size_t slot, bool trusted, MapInsertResult& r);
  // The share rule (header): other sources thinned to capacity / sources, candidate_ to the free
  // room, evenly along their order; counted in r.
  void make_room(std::size_t slot, MapInsertResult& r);
  // Thins every active source but `except` holding more than `share` points to `share`, evenly
  // along its order; returns the points dropped.
  std::uint32_t cut_sources(std::size_t share, std::size_t except);
  std::size_t capacity() const {
    return params_.max_points > 0 && params_.max_points < config::kMaxMapPoints ? params_.max_points
                                                                                 : config::kMaxMapPoints;
  }

  MapFusionParams params_;
  MapSourceInfo sources_[config::kMaxMapSources];
  Vec3f points_[config::kMaxMapPoints];
  std::uint8_t point_source_[config::kMaxMapPoints];
  std::uint32_t point_cells_[config::kMaxMapPoints][3];  // surveyed points: their reference cells' slots
  std::size_t num_points_ = 0;
  std::uint64_t revision_ = 0;
  MapFusionCounters counters_;

  FixedVector<Vec3f, config::kMaxMapInputPoints> staging_;
  FixedVector<Vec3f, config::kMaxMapPoints> candidate_;
  // Per source slot: the coarsening step its stored cloud needed. A sensor's clouds of one scene
  // have nearly the same number of voxels (EMBEDDED: a 16k-point infrastructure cloud ~12.6k at
  // 0.2 m, ~9.2k at 0.4 m, ~4.9k at 0.8 m for 8,192 places), so its next cloud is staged from the
  // finest step at which the stored cloud's voxels, x 2 per step finer, would fit: the finer
  // passes, each read until it overflows, would only prove again that they do. Not exact: a cloud
  // that would just fit a step finer is staged a step coarser (on the 12 recordings one Sim 1
  // cloud, 8,183 voxels at 0.4 m after 4,853 at 0.8 m).
  std::uint32_t coarsen_step_[config::kMaxMapSources] = {};
  std::uint32_t coarsen_voxels_[config::kMaxMapSources] = {};  // and its voxels at that step
  std::uint32_t staged_voxels_ = 0;                            // the last staged cloud's
  std::uint32_t first_coarsen_step(std::size_t slot) const;    // from those two
  FixedVector<std::uint32_t, config::kMapConsistencyPoints> overlap_;  // sampled candidate indices
  VoxelDownsampleStorage<config::kMapFusionHashSlots, config::kMaxMapPoints> downsample_;
  SourceCells cells_;
  BackgroundSlot backgrounds_[config::kMaxBackgroundUnits];
};

}  // namespace v2xloc
