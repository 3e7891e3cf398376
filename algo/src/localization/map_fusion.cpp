#include "v2xloc/algo/localization/map_fusion.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/coarsening_step.hpp"
#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/even_thinning.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);

}  // namespace

MapFusion::MapFusion(const MapFusionParams& params) : params_(params) {}

bool MapFusion::set_background(std::uint32_t source_id, const SurveyedBackground& background) {
  if (!background_valid(background)) return false;
  BackgroundSlot* slot = nullptr;
  for (BackgroundSlot& b : backgrounds_) {
    if (b.used && b.id == source_id) slot = &b;
  }
  for (BackgroundSlot& b : backgrounds_) {
    if (slot == nullptr && !b.used) slot = &b;
  }
  if (slot == nullptr) return false;
  *slot = BackgroundSlot{source_id, true, background};
  return true;
}

const SurveyedBackground* MapFusion::background(std::uint32_t source_id) const {
  for (const BackgroundSlot& b : backgrounds_) {
    if (b.used && b.id == source_id) return &b.background;
  }
  return nullptr;
}

BackgroundScore MapFusion::score_on_background(const SurveyedBackground& background, const Mat4d& world_T_sensor,
                                               std::span<const Vec3f> points) const {
  const Mat3d sensor_R_world = world_T_sensor.topLeftCorner<3, 3>().transpose();
  return check_background(background, points, sensor_R_world, params_.background);
}

bool MapFusion::fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor,
                                std::span<const Vec3f> points) const {
  const SurveyedBackground* b = params_.check_background ? background(source_id) : nullptr;
  return b == nullptr || score_on_background(*b, world_T_sensor, points).consistent;
}

bool MapFusion::passes_background(const SurveyedBackground& background, const Mat4d& world_T_sensor,
                                  std::span<const Vec3f> points, bool known_to_fit, MapInsertResult& r) {
  if (known_to_fit) {
    r.background.consistent = true;  // the caller's score (fits_background) on the same points
  } else {
    r.background = score_on_background(background, world_T_sensor, points);
  }
  r.background_checked = true;
  ++counters_.background_checked;
  if (r.background.consistent) return true;
  r.status = MapInsertStatus::kBackgroundMismatch;
  ++counters_.background_mismatch;
  return false;
}

void MapFusion::clear() {
  for (MapSourceInfo& s : sources_) s = MapSourceInfo{};
  num_points_ = 0;
  cells_.clear();
  ++revision_;
}

void MapFusion::remove_source_points(std::size_t slot) {
  if (sources_[slot].active && sources_[slot].trusted) clear_source_cells(slot);
  std::size_t n = 0;  // stable compaction keeps the other sources' order (determinism)
  for (std::size_t i = 0; i < num_points_; ++i) {
    if (point_source_[i] != slot) move_point(i, n++);
  }
  num_points_ = n;
  sources_[slot].points = 0;
}

void MapFusion::move_point(std::size_t from, std::size_t to) {
  points_[to] = points_[from];
  point_source_[to] = point_source_[from];
  for (int c = 0; c < 3; ++c) point_cells_[to][c] = point_cells_[from][c];
}

SourceCells::Mask MapFusion::trusted_bits(std::size_t slot) const {
  SourceCells::Mask bits = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (s != slot && sources_[s].active && sources_[s].trusted) bits = static_cast<SourceCells::Mask>(bits | (1u << s));
  }
  return bits;
}

void MapFusion::mark_source_cells(std::size_t slot, std::size_t first) {
  mark_cells(static_cast<SourceCells::Mask>(1u << slot), first);
}

void MapFusion::mark_cells(SourceCells::Mask sources, std::size_t first) {
  const double cells[3] = {0.5 * params_.inlier_distance, params_.overlap_cell, params_.agent_fill_cell};
  const std::uint64_t dropped_before = cells_.dropped();
  for (std::size_t i = first; i < num_points_; ++i) {
    const std::uint32_t source = point_source_[i];
    if (((sources >> source) & 1u) == 0) continue;
    const auto bit = static_cast<SourceCells::Mask>(1u << source);
    for (std::int32_t level = kInlierLevel; level <= kFillLevel; ++level) {
      std::int32_t key[3];
      const bool keyed = cells[level] > 0.0 && SourceCells::cell_key(points_[i], cells[level], level, key);
      point_cells_[i][level] = keyed ? cells_.add(key, bit) : SourceCells::kNoCell;
    }
  }
  counters_.reference_cells_dropped += cells_.dropped() - dropped_before;
}

void MapFusion::clear_source_cells(std::size_t slot) {
  set_recorded_cells(static_cast<SourceCells::Mask>(1u << slot), false);
}

// A point keeps its cells' slots until the table is rebuilt: its source's bit is set or cleared
// through them, no key hashed (re-setting them restores a thinned source's remaining cells). A
// cell that found no slot when marked stays unrecorded (it was counted then).
void MapFusion::set_recorded_cells(SourceCells::Mask sources, bool set) {
  for (std::size_t i = 0; i < num_points_; ++i) {
    const std::uint32_t source = point_source_[i];
    if (((sources >> source) & 1u) == 0) continue;
    const auto bit = static_cast<SourceCells::Mask>(1u << source);
    for (std::uint32_t c : point_cells_[i]) {
      if (set) {
        cells_.set_at(c, bit);
      } else {
        cells_.remove_at(c, bit);
      }
    }
  }
}

// Drops the emptied cells once they crowd the table: every surveyed source marked again.
bool MapFusion::rebuild_cells_if_crowded() {
  if (!cells_.needs_rebuild()) return false;
  cells_.clear();
  mark_cells(trusted_bits(config::kMaxMapSources), 0);  // every surveyed source, one pass over the map
  return true;
}

double MapFusion::consistency(std::size_t slot, double margin, std::uint32_t& overlap_points,
                              double& best_probe) {
  overlap_points = 0;
  best_probe = 0.0;
  // Fine cells of size inlier_distance / 2: a candidate with another source's point in its 27
  // neighbour cells has one within ~0.87 * inlier_distance * ... (<= 1.5 cells per axis).
  // The reference is the surveyed infrastructure only: agents never vouch for each other.
  const double fine = 0.5 * params_.inlier_distance;
  const SourceCells::Mask reference = trusted_bits(slot);
  // An even subsample of the candidate; the overlap count is scaled back to the whole cloud.
  const std::size_t cap = std::min<std::size_t>(
      params_.max_consistency_points > 0 ? params_.max_consistency_points : overlap_.capacity(), overlap_.capacity());
  const std::size_t stride = std::max<std::size_t>(1, (candidate_.size() + cap - 1) / cap);
  overlap_.clear();
  std::uint32_t inliers = 0;
  for (std::size_t i = 0; i < candidate_.size() && reference != 0; i += stride) {
    if (!cells_.any_around(candidate_[i], params_.overlap_cell, kOverlapLevel, reference)) continue;  // outside the others' region
    overlap_.push_back(static_cast<std::uint32_t>(i));  // <= cap samples: never full
    if (cells_.any_around(candidate_[i], fine, kInlierLevel, reference)) ++inliers;
  }
  overlap_points = static_cast<std::uint32_t>(overlap_.size() * stride);
  if (overlap_.empty()) return 1.0;
  const double fitness = static_cast<double>(inliers) / static_cast<double>(overlap_.size());
  if (overlap_points < params_.min_overlap_points) return fitness;  // no verdict: no probes
  // Shift probes over an even subsample of those (the same points for every probe).
  const float d = static_cast<float>(params_.probe_step);
  const Vec3f probes[] = {{d, 0, 0},  {-d, 0, 0}, {0, d, 0},      {0, -d, 0},      {d, d, 0},  {d, -d, 0},
                          {-d, d, 0}, {-d, -d, 0}, {2 * d, 0, 0}, {-2 * d, 0, 0}, {0, 2 * d, 0}, {0, -2 * d, 0}};
  const std::size_t n = overlap_.size();
  const std::size_t probe_stride =
      params_.max_probe_points > 0 ? (n + params_.max_probe_points - 1) / params_.max_probe_points : 1;
  const auto total = static_cast<std::uint32_t>((n + probe_stride - 1) / probe_stride);
  const double beat = fitness + margin;  // the verdict: does any probe score above this?
  for (const Vec3f& o : probes) {
    std::uint32_t hits = 0, misses = 0;
    bool can_beat = true;
    for (std::size_t k = 0; k < n && can_beat; k += probe_stride) {
      if (cells_.any_around(candidate_[overlap_[k]] + o, fine, kInlierLevel, reference)) {
        ++hits;
      } else {
        ++misses;  // even if every remaining point hits, the probe scores (total - misses) / total
        can_beat = static_cast<double>(total - misses) / total > beat;
      }
    }
    const double f = static_cast<double>(hits) / total;  // exact when the probe ran to the end
    if (f > best_probe) best_probe = f;
  }
  return fitness;
}

std::uint32_t MapFusion::other_trusted(std::size_t slot) const {
  std::uint32_t n = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) n += (s != slot && sources_[s].active && sources_[s].trusted) ? 1u : 0u;
  return n;
}

std::uint32_t MapFusion::drop_covered_by_trusted(std::size_t slot) {
  const SourceCells::Mask reference = trusted_bits(slot);
  if (reference == 0) return 0;
  std::size_t kept = 0;
  for (std::size_t k = 0; k < candidate_.size(); ++k) {
    if (!cells_.any_around(candidate_[k], params_.agent_fill_cell, kFillLevel, reference)) candidate_[kept++] = candidate_[k];
  }
  const auto dropped = static_cast<std::uint32_t>(candidate_.size() - kept);
  candidate_.resize(kept);
  return dropped;
}

std::size_t MapFusion::find_source(std::uint32_t source_id) const {
  std::size_t slot = config::kMaxMapSources;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (sources_[s].active && sources_[s].id == source_id) slot = s;
  }
  return slot;
}

std::size_t MapFusion::claim_source_slot(bool trusted, double timestamp, bool& displace) const {
  // Per-role cap: at the cap, a new source may only displace the oldest source of its own role.
  std::uint32_t same_role = 0;
  for (const MapSourceInfo& s : sources_) same_role += (s.active && s.trusted == trusted) ? 1u : 0u;
  const bool at_cap = same_role >= (trusted ? params_.max_trusted_sources : params_.max_agent_sources);
  std::size_t slot = config::kMaxMapSources;
  for (std::size_t s = 0; s < config::kMaxMapSources && slot == config::kMaxMapSources && !at_cap; ++s) {
    if (!sources_[s].active) slot = s;
  }
  if (slot != config::kMaxMapSources) return slot;
  std::size_t oldest = config::kMaxMapSources;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!sources_[s].active || sources_[s].trusted != trusted) continue;
    if (oldest == config::kMaxMapSources || sources_[s].timestamp < sources_[oldest].timestamp)
      oldest = s;
  }
  if (oldest < config::kMaxMapSources && sources_[oldest].timestamp < timestamp) {
    displace = true;
    return oldest;
  }
  return config::kMaxMapSources;
}

// Into the global frame (double math), non-finite points dropped, then downsampled.
void MapFusion::stage_candidate(const Mat4d& world_T_sensor, std::span<const Vec3f> points, std::uint32_t first_step,
                                MapInsertResult& r) {
  staging_.clear();
  const Mat3d R = world_T_sensor.topLeftCorner<3, 3>();
  const Vec3d t = world_T_sensor.topRightCorner<3, 1>();
  const std::size_t limit = params_.max_input_points;  // 0: none (the staging's capacity cuts, counted)
  const std::size_t cap = std::min(limit, staging_.capacity());
  const std::size_t stride = limit > 0 && points.size() > cap ? (points.size() + cap - 1) / cap : 1;
  if (stride > 1) {
    r.input_thinned = static_cast<std::uint32_t>(points.size() - (points.size() + stride - 1) / stride);
    counters_.input_points_thinned += r.input_thinned;
  }
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const Vec3f& p = points[i];
    if (!p.allFinite()) {
      ++r.non_finite_dropped;
      continue;
    }
    if (!staging_.push_back((R * p.cast<double>() + t).cast<float>())) ++r.capacity_dropped;
  }
  candidate_.clear();
  const auto voxel = static_cast<float>(params_.voxel_size);
  // More voxels than the candidate holds: the output would be cut in scan order (whole sectors
  // lost); the cloud is downsampled again with the voxel doubled instead (params). A pass that
  // will be read again ends as soon as it overflows: only that it does counts.
  const std::uint32_t steps = params_.max_coarsen_steps;
  const auto voxel_at = [voxel](std::uint32_t step) { return step == 0 ? voxel : voxel * static_cast<float>(1u << step); };
  std::uint32_t step = std::min(first_step, steps);
  VoxelDownsampleResult ds = downsample_.run(staging_.span(), voxel_at(step), candidate_, SIZE_MAX, step < steps);
  while (step < steps && ds.output_overflow > 0) {
    ++step;
    ds = downsample_.run(staging_.span(), voxel_at(step), candidate_, SIZE_MAX, step < steps);
  }
  r.coarsened = step;
  staged_voxels_ = ds.output_points;
  if (r.coarsened > 0) ++counters_.clouds_coarsened;
  r.capacity_dropped += ds.output_overflow + ds.hash_overflow + ds.range_overflow;
  counters_.non_finite_dropped += r.non_finite_dropped;
}

// The finest step, at most the stored cloud's, at which its voxels, x 2 per step finer, fit.
std::uint32_t MapFusion::first_coarsen_step(std::size_t slot) const {
  return finest_fitting_step(coarsen_step_[slot], params_.max_coarsen_steps, static_cast<double>(coarsen_voxels_[slot]),
                             2.0, static_cast<double>(candidate_.capacity()));
}

bool MapFusion::passes_consistency(std::size_t own_slot, bool trusted, MapInsertResult& r) {
  // Agents against the infrastructure: low fitness, or a better fit shifted, is a wrong pose;
  // too little overlap to tell is held back (an agent whose cloud cannot be checked adds
  // nothing the map can trust). Infrastructure units against each other where they overlap:
  // their absolute fitness is low even for exact poses (different faces of the buildings), so
  // only the shift test applies, and without overlap a surveyed unit is accepted.
  // With two or more other units the quorum rule applies (map_fusion.hpp: infra_quorum_*).
  const std::uint32_t others = trusted ? other_trusted(own_slot) : 0;
  const bool quorum = trusted && others >= 2;
  const double margin = !trusted ? params_.probe_margin : quorum ? params_.infra_quorum_margin : params_.infra_probe_margin;
  r.consistency_fitness = consistency(own_slot, margin, r.overlap_points, r.best_probe_fitness);
  const bool checkable = r.overlap_points >= params_.min_overlap_points;
  const bool shifted = checkable && r.best_probe_fitness > r.consistency_fitness + margin;
  const double floor = !trusted ? params_.min_fitness : others >= 3 ? params_.infra_quorum_min_fitness : 0.0;
  // Too little overlap to be checked: an agent always, an infrastructure unit once two or more
  // others form a quorum it should share the scene with (a cloud moved out of all overlap, e.g.
  // points shifted 200 m under a true pose, would otherwise pass unchecked). A unit held back by
  // the quorum loses its stored cloud as an outvoted one does.
  if (!checkable && (!trusted || quorum)) {
    r.status = MapInsertStatus::kHeldBack;
    ++counters_.held_back;
    if (quorum) ++counters_.infra_unchecked;
    r.outvoted = quorum;
    return false;
  }
  if (shifted || (checkable && r.consistency_fitness < floor)) {  // agents here are checkable
    r.status = MapInsertStatus::kRejectedInconsistent;
    ++counters_.rejected_inconsistent;
    if (quorum) ++counters_.infra_outvoted;
    r.outvoted = quorum;
    r.quorum_checked = others >= 3 && checkable;
    return false;
  }
  r.quorum_checked = trusted && others >= 3 && checkable;  // the full rule: peak and floor
  if (!checkable) r.consistency_fitness = 1.0;
  return true;
}

std::uint32_t MapFusion::cut_sources(std::size_t share, std::size_t except) {
  bool over[config::kMaxMapSources] = {};
  bool any = false;
  SourceCells::Mask remark = 0;  // surveyed sources thinned: their bits set again from the kept points
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    over[s] = s != except && sources_[s].active && sources_[s].points > share;
    any |= over[s];
    if (over[s] && sources_[s].trusted) remark = static_cast<SourceCells::Mask>(remark | (1u << s));
  }
  if (!any) return 0;
  set_recorded_cells(remark, false);
  std::size_t seen[config::kMaxMapSources] = {};
  std::size_t n = 0;  // stable compaction, as remove_source_points
  for (std::size_t i = 0; i < num_points_; ++i) {
    const std::uint8_t s = point_source_[i];
    if (!over[s] || kept_evenly(seen[s]++, sources_[s].points, share)) move_point(i, n++);
  }
  const auto dropped = static_cast<std::uint32_t>(num_points_ - n);
  num_points_ = n;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (over[s]) sources_[s].points = static_cast<std::uint32_t>(share);
  }
  set_recorded_cells(remark, true);
  return dropped;
}

void MapFusion::make_room(std::size_t slot, MapInsertResult& r) {
  std::size_t sources = 1;  // this one (its slot is not active yet when it is new)
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) sources += (s != slot && sources_[s].active) ? 1u : 0u;
  r.share_trimmed = cut_sources(capacity() / sources, slot);
  counters_.points_trimmed_share += r.share_trimmed;
  // The others now hold <= a share each: the room is >= a share (more when some hold less).
  const std::size_t room = capacity() - std::min(num_points_, capacity());
  const std::size_t n = candidate_.size();
  if (n <= room) return;
  std::size_t kept = 0;
  for (std::size_t j = 0; j < n; ++j) {
    if (kept_evenly(j, n, room)) candidate_[kept++] = candidate_[j];
  }
  candidate_.resize(kept);
  r.capacity_dropped += static_cast<std::uint32_t>(n - kept);
}

std::uint32_t MapFusion::store_candidate(std::size_t slot, bool trusted, MapInsertResult& r) {
  if (candidate_.size() + num_points_ > capacity()) make_room(slot, r);
  const std::size_t first = num_points_;
  std::uint32_t stored = 0;
  for (const Vec3f& p : candidate_) {
    if (num_points_ >= capacity()) {
      ++r.capacity_dropped;
      continue;
    }
    points_[num_points_] = p;
    point_source_[num_points_] = static_cast<std::uint8_t>(slot);
    ++num_points_;
    ++stored;
  }
  if (trusted) mark_source_cells(slot, first);  // the reference cells follow the surveyed points
  return stored;
}

MapInsertResult MapFusion::insert(std::uint32_t source_id, double timestamp,
                                  const Pose3d& world_T_sensor_pose, std::span<const Vec3f> points,
                                  bool trusted, bool background_fits) {
  const Mat4d& world_T_sensor = world_T_sensor_pose.matrix();
  MapInsertResult r;
  r.input_points = static_cast<std::uint32_t>(points.size());
  if (!std::isfinite(timestamp) || !world_T_sensor.allFinite()) return r;

  // Source slot: same id, else a free slot, else the oldest if older than this cloud.
  std::size_t slot = find_source(source_id);
  const bool known = slot < config::kMaxMapSources;
  if (known && !(timestamp > sources_[slot].timestamp)) {
    r.status = MapInsertStatus::kStale;
    ++counters_.stale;
    return r;
  }
  bool displace = false;
  if (!known) slot = claim_source_slot(trusted, timestamp, displace);
  if (slot == config::kMaxMapSources) {
    r.status = MapInsertStatus::kNoSourceSlot;
    ++counters_.no_source_slot;
    return r;
  }

  // A unit with a surveyed background shows it, or nothing of its cloud is used (checked on the
  // sensor-frame points before any staging; the other checks below still apply to it).
  const SurveyedBackground* background = trusted && params_.check_background ? this->background(source_id) : nullptr;
  if (background != nullptr && !passes_background(*background, world_T_sensor, points, background_fits, r)) return r;

  stage_candidate(world_T_sensor, points, known ? first_coarsen_step(slot) : 0u, r);
  // The source's previous cloud is left out of the reference (a displaced slot is not its own).
  const std::size_t own_slot = known ? slot : config::kMaxMapSources;
  if (params_.check_consistency && !candidate_.empty() && !passes_consistency(own_slot, trusted, r)) {
    // An outvoted unit's older cloud goes too: it may have been accepted before a quorum existed
    // (the first share of the first unit to send is checked against nothing).
    if (r.outvoted && known) evict_outvoted(slot);
    return r;
  }
  if (!trusted && params_.agent_fill_cell > 0.0) {
    r.covered_dropped = drop_covered_by_trusted(own_slot);
    counters_.agent_points_covered += r.covered_dropped;
  }

  if (known || displace) remove_source_points(slot);
  if (displace) ++counters_.sources_evicted_slot;
  const std::uint32_t stored = store_candidate(slot, trusted, r);
  coarsen_step_[slot] = r.coarsened;
  coarsen_voxels_[slot] = staged_voxels_;
  counters_.points_dropped_capacity += r.capacity_dropped;
  MapSourceInfo& info = sources_[slot];
  info.id = source_id;
  info.timestamp = timestamp;
  info.world_T_sensor = world_T_sensor_pose;
  info.points = stored;
  info.active = true;
  info.trusted = trusted;
  info.vetted = r.quorum_checked;
  r.cells_rebuilt = rebuild_cells_if_crowded();  // after the slot's flags are set: a rebuild marks it too
  r.stored_points = stored;
  r.status = known ? MapInsertStatus::kReplaced : MapInsertStatus::kInserted;
  if (known) ++counters_.replaced;
  else ++counters_.inserted;
  ++revision_;
  if (trusted && params_.check_consistency) r.units_vetted = vet_infrastructure();
  return r;
}

void MapFusion::evict_outvoted(std::size_t slot) {
  remove_source_points(slot);
  sources_[slot] = MapSourceInfo{};
  ++counters_.infra_evicted;
  ++revision_;
}

std::uint32_t MapFusion::vet_infrastructure() {
  std::uint32_t checked = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!sources_[s].active || !sources_[s].trusted || sources_[s].vetted || other_trusted(s) < 3) continue;
    ++checked;
    candidate_.clear();  // free after the insert: the stored cloud is scored as a candidate would be
    for (std::size_t i = 0; i < num_points_; ++i) {
      if (point_source_[i] == s) candidate_.push_back(points_[i]);
    }
    MapInsertResult r;
    if (candidate_.empty() || passes_consistency(s, true, r)) {
      sources_[s].vetted = r.quorum_checked;
    } else if (r.outvoted) {
      evict_outvoted(s);
    }
  }
  return checked;
}

std::uint32_t MapFusion::expire(double now) {
  std::uint32_t evicted = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!sources_[s].active || !(now - sources_[s].timestamp > params_.max_age)) continue;
    remove_source_points(s);
    sources_[s] = MapSourceInfo{};
    ++evicted;
  }
  if (evicted > 0) {
    counters_.sources_evicted_age += evicted;
    ++revision_;
  }
  return evicted;
}

MapExtractResult MapFusion::extract(BoundedVector<Vec3f>& out) {
  MapExtractResult r;
  out.clear();
  const VoxelDownsampleResult ds = downsample_.run(
      std::span<const Vec3f>(points_, num_points_), static_cast<float>(params_.voxel_size), out);
  r.points = static_cast<std::uint32_t>(out.size());
  r.capacity_dropped = ds.output_overflow + ds.hash_overflow + ds.range_overflow;
  return r;
}

}  // namespace v2xloc
