#include "v2xloc/algo/localization/map_fusion.hpp"

#include <cmath>

#include "v2xloc/algo/core/spatial_hash.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);
}  // namespace

MapFusion::MapFusion(const MapFusionParams& params) : params_(params) {}

void MapFusion::clear() {
  for (MapSourceInfo& s : sources_) s = MapSourceInfo{};
  for (std::size_t& f : first_point_) f = 0;
  quorum_.clear();
  num_points_ = 0;
  ++revision_;
}

void MapFusion::remove_source_points(std::size_t slot) {
  const std::size_t removed = sources_[slot].points;
  std::size_t n = 0;  // stable compaction keeps the other sources' order (determinism)
  for (std::size_t i = 0; i < num_points_; ++i) {
    if (point_source_[i] == slot) continue;
    points_[n] = points_[i];
    point_source_[n] = point_source_[i];
    ++n;
  }
  num_points_ = n;
  sources_[slot].points = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (s != slot && first_point_[s] > first_point_[slot]) first_point_[s] -= removed;  // blocks after it
  }
}

void MapFusion::release_slot(std::size_t slot) {
  remove_source_points(slot);
  sources_[slot] = MapSourceInfo{};
  quorum_.forget(slot);
}

bool MapFusion::cell_key(const Vec3f& p, double cell, std::int32_t key[3]) const {
  for (int i = 0; i < 3; ++i) {
    const double k = std::floor(static_cast<double>(p(i)) / cell);
    if (!(k > -268435456.0 && k < 268435456.0)) return false;
    key[i] = static_cast<std::int32_t>(k);
  }
  return true;
}

bool MapFusion::mark(const std::int32_t key[3]) {
  return linear_probe(spatial_hash(key), kSlots, kMaxProbes, [&](std::size_t slot) {
           Cell& c = cells_[slot];
           if (c.stamp != stamp_) {
             c.key[0] = key[0];
             c.key[1] = key[1];
             c.key[2] = key[2];
             c.stamp = stamp_;
             return true;
           }
           return c.key[0] == key[0] && c.key[1] == key[1] && c.key[2] == key[2];
         }).stopped;
}

bool MapFusion::occupied(const std::int32_t key[3]) const {
  bool found = false;
  linear_probe(spatial_hash(key), kSlots, kMaxProbes, [&](std::size_t slot) {
    const Cell& c = cells_[slot];
    if (c.stamp != stamp_) return true;
    found = c.key[0] == key[0] && c.key[1] == key[1] && c.key[2] == key[2];
    return found;
  });
  return found;
}

bool MapFusion::occupied_around(const Vec3f& p, double cell) const {
  std::int32_t key[3];
  if (!cell_key(p, cell, key)) return false;
  for (int dx = -1; dx <= 1; ++dx)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dz = -1; dz <= 1; ++dz) {
        const std::int32_t k[3] = {key[0] + dx, key[1] + dy, key[2] + dz};
        if (occupied(k)) return true;
      }
  return false;
}

// Fresh table generation: marks from earlier calls become empty without clearing.
void MapFusion::new_cell_generation() {
  if (++stamp_ == 0) {
    for (Cell& c : cells_) c.stamp = 0;
    stamp_ = 1;
  }
}

std::uint32_t MapFusion::drop_covered_by_trusted() {
  new_cell_generation();
  bool any = false;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!sources_[s].active || !sources_[s].trusted || !sources_[s].fused) continue;
    std::int32_t key[3];
    for (const Vec3f& p : source_points(s)) {
      if (cell_key(p, params_.agent_fill_cell, key)) any = mark(key) || any;
    }
  }
  if (!any) return 0;
  std::size_t kept = 0;
  for (std::size_t k = 0; k < candidate_.size(); ++k) {
    if (!occupied_around(candidate_[k], params_.agent_fill_cell)) candidate_[kept++] = candidate_[k];
  }
  const auto dropped = static_cast<std::uint32_t>(candidate_.size() - kept);
  candidate_.resize(kept);
  return dropped;
}

// Same id, else a free slot of the role's quota, else the role's oldest source if older than
// this cloud (displace); kMaxMapSources when none (status set).
std::size_t MapFusion::find_slot(std::uint32_t source_id, double timestamp, bool trusted, MapInsertResult& r,
                                 bool& displace) {
  displace = false;
  std::size_t slot = config::kMaxMapSources;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (sources_[s].active && sources_[s].id == source_id) slot = s;
  }
  if (slot < config::kMaxMapSources) {
    if (timestamp > sources_[slot].timestamp) return slot;
    r.status = MapInsertStatus::kStale;
    ++counters_.stale;
    return config::kMaxMapSources;
  }
  std::uint32_t same_role = 0;
  for (const MapSourceInfo& s : sources_) same_role += (s.active && s.trusted == trusted) ? 1u : 0u;
  const bool at_cap = same_role >= (trusted ? params_.max_trusted_sources : params_.max_agent_sources);
  for (std::size_t s = 0; s < config::kMaxMapSources && slot == config::kMaxMapSources && !at_cap; ++s) {
    if (!sources_[s].active) slot = s;
  }
  if (slot == config::kMaxMapSources) {
    std::size_t oldest = config::kMaxMapSources;
    for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
      if (!sources_[s].active || sources_[s].trusted != trusted) continue;
      if (oldest == config::kMaxMapSources || sources_[s].timestamp < sources_[oldest].timestamp) oldest = s;
    }
    if (oldest < config::kMaxMapSources && sources_[oldest].timestamp < timestamp) {
      slot = oldest;
      displace = true;
    }
  }
  if (slot == config::kMaxMapSources) {
    r.status = MapInsertStatus::kNoSourceSlot;
    ++counters_.no_source_slot;
  }
  return slot;
}

// Into the global frame (double math), non-finite points dropped, then downsampled.
void MapFusion::stage_cloud(const Mat4d& world_T_sensor, std::span<const Vec3f> points, MapInsertResult& r) {
  staging_.clear();
  const Mat3d R = world_T_sensor.topLeftCorner<3, 3>();
  const Vec3d t = world_T_sensor.topRightCorner<3, 1>();
  for (const Vec3f& p : points) {
    if (!p.allFinite()) {
      ++r.non_finite_dropped;
      continue;
    }
    if (!staging_.push_back((R * p.cast<double>() + t).cast<float>())) ++r.capacity_dropped;
  }
  candidate_.clear();
  const VoxelDownsampleResult ds = downsample_.run(staging_.span(), static_cast<float>(params_.voxel_size), candidate_);
  r.capacity_dropped += ds.output_overflow + ds.hash_overflow + ds.range_overflow;
  counters_.non_finite_dropped += r.non_finite_dropped;
}

// Keeps the check with the most matched points as the result's report, and counts its verdict.
void MapFusion::fold_check(const MapCheckResult& c, MapInsertResult& r) const {
  if (c.verdict == MapCheckVerdict::kAgree) ++r.agreeing;
  else if (c.verdict == MapCheckVerdict::kDisagree) ++r.disagreeing;
  else ++r.uncheckable;
  if (r.agreeing + r.disagreeing + r.uncheckable == 1 || c.matched_points > r.check.matched_points) r.check = c;
}

// The candidate against every other stored unit, pair by pair (the quorum needs each verdict).
void MapFusion::check_infrastructure(std::size_t slot, MapInsertResult& r) {
  counters_.check_cells_dropped += check_.set_candidate(candidate_.span(), params_);
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (s == slot || !sources_[s].active || !sources_[s].trusted) continue;
    const std::span<const Vec3f> range[1] = {source_points(s)};
    const MapCheckResult c = check_.check(range, params_.max_offset_infra);
    quorum_.record(slot, s, c.verdict);
    fold_check(c, r);
  }
}

// The candidate agent against the fused infrastructure as one reference (agents never vouch for
// each other). Sets the status when the agent is not to be stored.
void MapFusion::check_agent(MapInsertResult& r) {
  std::span<const Vec3f> ranges[config::kMaxMapSources];
  std::size_t n = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (sources_[s].active && sources_[s].trusted && sources_[s].fused) ranges[n++] = source_points(s);
  }
  if (n > 0) {
    counters_.check_cells_dropped += check_.set_candidate(candidate_.span(), params_);
    fold_check(check_.check(std::span<const std::span<const Vec3f>>(ranges, n), params_.max_offset_agent), r);
  } else {
    ++r.uncheckable;  // no fused infrastructure: nothing to check against
  }
  if (r.agreeing == 1) return;
  r.status = r.disagreeing == 1 ? MapInsertStatus::kRejectedInconsistent : MapInsertStatus::kHeldBack;
}

// Fused iff the quorum says so, for every stored unit; returns the standing of `slot`.
QuorumStanding MapFusion::arbitrate(std::size_t slot) {
  bool stored[InfraQuorum::kSlots] = {};
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) stored[s] = sources_[s].active && sources_[s].trusted;
  QuorumStanding own;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!stored[s]) continue;
    const QuorumStanding q = quorum_.standing(s, stored);
    if (s == slot) own = q;
    const bool fused = q.fused();
    if (fused == sources_[s].fused) continue;
    sources_[s].fused = fused;
    ++revision_;
    if (s == slot) continue;
    if (fused) ++counters_.quorum_promoted;
    else ++counters_.quorum_demoted;
  }
  return own;
}

// The candidate replaces the slot's points (appended: each source's points stay contiguous).
void MapFusion::store(std::size_t slot, bool replaced, std::uint32_t source_id, double timestamp,
                      const Mat4d& world_T_sensor, bool trusted, MapInsertResult& r) {
  if (replaced) remove_source_points(slot);
  first_point_[slot] = num_points_;
  std::uint32_t stored = 0;
  for (const Vec3f& p : candidate_) {
    if (num_points_ == config::kMaxMapPoints) {
      ++r.capacity_dropped;
      continue;
    }
    points_[num_points_] = p;
    point_source_[num_points_] = static_cast<std::uint8_t>(slot);
    ++num_points_;
    ++stored;
  }
  counters_.points_dropped_capacity += r.capacity_dropped;
  MapSourceInfo& info = sources_[slot];
  info.id = source_id;
  info.timestamp = timestamp;
  info.world_T_sensor = world_T_sensor;
  info.points = stored;
  info.active = true;
  info.trusted = trusted;
  info.fused = !trusted;  // agents are stored only when they agree; units by arbitrate()
  r.stored_points = stored;
  ++revision_;
}

MapInsertResult MapFusion::insert(std::uint32_t source_id, double timestamp, const Mat4d& world_T_sensor,
                                  std::span<const Vec3f> points, bool trusted) {
  MapInsertResult r;
  r.input_points = static_cast<std::uint32_t>(points.size());
  if (!std::isfinite(timestamp) || !world_T_sensor.allFinite()) return r;
  bool displace = false;
  const std::size_t slot = find_slot(source_id, timestamp, trusted, r, displace);
  if (slot == config::kMaxMapSources) return r;
  const bool known = sources_[slot].active && !displace;
  stage_cloud(world_T_sensor, points, r);
  const bool check = params_.check_consistency && !candidate_.empty();
  if (!trusted && check) {
    check_agent(r);
    if (r.status != MapInsertStatus::kInvalidInput) {  // not stored: the slot keeps its cloud
      if (r.status == MapInsertStatus::kHeldBack) ++counters_.held_back;
      else ++counters_.rejected_inconsistent;
      return r;
    }
  }
  if (!trusted && params_.agent_fill_cell > 0.0) {
    r.covered_dropped = drop_covered_by_trusted();
    counters_.agent_points_covered += r.covered_dropped;
  }
  if (displace) {
    release_slot(slot);
    ++counters_.sources_evicted_slot;
  }
  if (!known) quorum_.forget(slot);
  if (trusted && check) check_infrastructure(slot, r);
  store(slot, known, source_id, timestamp, world_T_sensor, trusted, r);
  r.status = known ? MapInsertStatus::kReplaced : MapInsertStatus::kInserted;
  if (trusted) {
    const QuorumStanding q = check ? arbitrate(slot) : QuorumStanding{};
    if (!check) sources_[slot].fused = true;
    if (check && !q.fused()) {
      r.status = q.disagree > q.agree + q.upheld ? MapInsertStatus::kRejectedInconsistent : MapInsertStatus::kHeldBack;
      if (r.status == MapInsertStatus::kHeldBack) ++counters_.held_back;
      else ++counters_.rejected_inconsistent;
      return r;
    }
  }
  if (known) ++counters_.replaced;
  else ++counters_.inserted;
  return r;
}

std::uint32_t MapFusion::expire(double now) {
  std::uint32_t evicted = 0;
  for (std::size_t s = 0; s < config::kMaxMapSources; ++s) {
    if (!sources_[s].active || !(now - sources_[s].timestamp > params_.max_age)) continue;
    release_slot(s);
    ++evicted;
  }
  if (evicted > 0) {
    counters_.sources_evicted_age += evicted;
    ++revision_;
    if (params_.check_consistency) arbitrate(config::kMaxMapSources);  // the remaining units decide
  }
  return evicted;
}

MapExtractResult MapFusion::extract(BoundedVector<Vec3f>& out) {
  MapExtractResult r;
  out.clear();
  // Only fused sources; the stored points are used directly when every source is fused.
  std::span<const Vec3f> fused(points_, num_points_);
  bool all_fused = true;
  for (const MapSourceInfo& s : sources_) all_fused = all_fused && (!s.active || s.fused);
  if (!all_fused) {
    staging_.clear();
    for (std::size_t i = 0; i < num_points_; ++i) {
      if (sources_[point_source_[i]].fused) staging_.push_back(points_[i]);
    }
    fused = staging_.span();
  }
  const VoxelDownsampleResult ds = downsample_.run(fused, static_cast<float>(params_.voxel_size), out);
  r.points = static_cast<std::uint32_t>(out.size());
  r.capacity_dropped = ds.output_overflow + ds.hash_overflow + ds.range_overflow;
  return r;
}

}  // namespace v2xloc
