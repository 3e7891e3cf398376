#include "v2xloc/algo/localization/odometry_map.hpp"

#include <algorithm>
#include <cstring>
#include <type_traits>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"
#include "v2xloc/algo/core/unroll.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);

Vec3d transform(const Mat4d& T, const Vec3f& p) {
  return T.topLeftCorner<3, 3>() * p.cast<double>() + T.topRightCorner<3, 1>();
}
}  // namespace

void OdometryVoxelMap::configure(double voxel_size, std::uint32_t max_points_per_voxel) {
  voxel_size_ = voxel_size;
  max_per_voxel_ = std::clamp<std::uint32_t>(max_points_per_voxel, 1u,
                                             static_cast<std::uint32_t>(config::kOdometryMaxPointsPerVoxel));
  clear();
}

void OdometryVoxelMap::clear() {
  for (std::size_t i = 0; i < num_voxels_; ++i) slots_[voxels_[i].slot] = 0;
  num_points_ = 0;
  num_voxels_ = 0;
}

bool OdometryVoxelMap::voxel_key(const Vec3d& p, std::int32_t key[3]) const {
  double quotient[3];
  return voxel_key(p, key, quotient);
}

bool OdometryVoxelMap::voxel_key(const Vec3d& p, std::int32_t key[3], double quotient[3]) const {
  V2XLOC_UNROLL_AXES for (int i = 0; i < 3; ++i) {
    const double q = p(i) / voxel_size_;
    if (!(q > -1073741824.0 && q < 1073741824.0)) return false;  // |key| < 2^30
    key[i] = det::floor_to_int(q);  // libm's floor is a call on baseline x86-64
    if (key[i] == -1073741824) return false;
    quotient[i] = q;
  }
  return true;
}

std::uint32_t OdometryVoxelMap::find_voxel(const std::int32_t key[3]) const {
  return find_indexed(slots_, kSlots, kMaxProbes, voxels_, key);
}

static_assert(std::is_trivially_copyable_v<MapPoint> && sizeof(MapPoint) == 3 * sizeof(float));

std::span<const MapPoint> OdometryVoxelMap::voxel_points(const std::int32_t key[3]) const {
  const std::uint32_t v = find_voxel(key);
  if (v == kNone) return {};
  const Voxel& vx = voxels_[v];
  return {map_[active_] + vx.begin, vx.count};
}

std::uint32_t OdometryVoxelMap::insert_voxel(const std::int32_t key[3]) {
  if (num_voxels_ == kMaxPoints) return kNone;
  const ProbeResult probe = linear_probe(spatial_hash_folded(key), kSlots, kMaxProbes,
                                         [&](std::size_t slot) { return slots_[slot] == 0; });
  if (!probe.stopped) return kNone;
  Voxel& vx = voxels_[num_voxels_];
  vx = Voxel{{key[0], key[1], key[2]}, 0, 0, 0, static_cast<std::uint32_t>(probe.slot),
             {INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
  slots_[probe.slot] = static_cast<std::uint32_t>(++num_voxels_);
  return static_cast<std::uint32_t>(num_voxels_ - 1);
}

// The nearest map point among the 2 x 2 x 2 voxels around p (its own and, per axis, the
// neighbour on the side p lies in): exact for every point within half a voxel of p, which
// covers the tracking threshold tau; 8 voxel lookups instead of KISS-ICP's 27, once per block
// (NeighborBlock). A neighbour voxel whose cell lies farther than the best match so far is not
// scanned, nor is a voxel whose points' bounding box does: neither can hold a closer point.
bool OdometryVoxelMap::nearest(const Vec3d& p, double max_d2, Vec3d& q, double& d2) const {
  NeighborBlock block;
  block.lo[0] = kNoBlock;
  return nearest(p, max_d2, q, d2, block);
}

namespace {
// Own voxel, faces, edges, corner: the search order of a block's voxels, as offsets from the own
// voxel (x 1, y 2, z 4).
constexpr int kCornerOrder[8] = {0, 1, 2, 4, 3, 5, 6, 7};
}  // namespace

// The block's non-empty voxels in search order.
void OdometryVoxelMap::fill_block(const std::int32_t lo[3], int own, NeighborBlock& block) const {
  V2XLOC_UNROLL_AXES for (int a = 0; a < 3; ++a) block.lo[a] = lo[a];
  block.own = static_cast<std::uint8_t>(own);
  block.count = 0;
  for (int c = 0; c < 8; ++c) {
    const int offset = own ^ kCornerOrder[c];
    const std::int32_t k[3] = {lo[0] + (offset & 1), lo[1] + ((offset >> 1) & 1), lo[2] + ((offset >> 2) & 1)};
    const std::uint32_t v = find_voxel(k);
    if (v == kNone) continue;
    block.rank[block.count] = static_cast<std::uint8_t>(c);
    block.voxel[block.count] = static_cast<BlockVoxel>(v);
    ++block.count;
  }
}

bool OdometryVoxelMap::nearest(const Vec3d& p, double max_d2, Vec3d& q, double& d2, NeighborBlock& block) const {
  std::int32_t key[3];
  double quotient[3];
  if (!voxel_key(p, key, quotient)) return false;
  std::int32_t side[3];
  double gap2[3];  // squared distance from p to the neighbour voxel's face, per axis
  V2XLOC_UNROLL_AXES for (int a = 0; a < 3; ++a) {
    const double frac = quotient[a] - key[a];
    side[a] = frac < 0.5 ? -1 : 1;
    const double gap = (side[a] < 0 ? frac : 1.0 - frac) * voxel_size_;
    gap2[a] = gap * gap;
  }
  // The block's lowest key, and p's own voxel's offset in it (per axis bit: 1 when p lies in the
  // upper half of the block).
  const std::int32_t lo[3] = {key[0] + (side[0] < 0 ? -1 : 0), key[1] + (side[1] < 0 ? -1 : 0),
                              key[2] + (side[2] < 0 ? -1 : 0)};
  const int own = (side[0] < 0 ? 1 : 0) | (side[1] < 0 ? 2 : 0) | (side[2] < 0 ? 4 : 0);
  if (block.lo[0] != lo[0] || block.lo[1] != lo[1] || block.lo[2] != lo[2] || block.own != own) {
    fill_block(lo, own, block);
  }
  // Each cell's squared distance summed over the axes in x, y, z order (formed once here
  // instead of per cell), by place in the search order.
  const double box2[8] = {0.0,
                          gap2[0],
                          gap2[1],
                          gap2[2],
                          gap2[0] + gap2[1],
                          gap2[0] + gap2[2],
                          gap2[1] + gap2[2],
                          (gap2[0] + gap2[1]) + gap2[2]};
  d2 = max_d2;
  const MapPoint* best = nullptr;
  for (int j = 0; j < block.count; ++j) {
    // 0.1 % slack: voxel keys are floors of rounded quotients
    if (box2[block.rank[j]] * 0.999 >= d2) continue;
    scan_voxel(voxels_[block.voxel[j]], p, d2, best);
  }
  if (best == nullptr) return false;
  q = Vec3d(best->x, best->y, best->z);
  return true;
}

// Squared distances are formed as dx^2 + (dy^2 + dz^2), each d = m - p in double, as Eigen's
// squaredNorm does (its unrolled sum halves the vector); dx^2 and the box's gaps are lower bounds
// of that sum in floating point too (rounding is monotone), so every skip below only drops
// points with d >= d2: the same result as scanning them all.
void OdometryVoxelMap::scan_voxel(const Voxel& vx, const Vec3d& p, double& d2, const MapPoint*& best) const {
  double box[3];
  V2XLOC_UNROLL_AXES for (int a = 0; a < 3; ++a) {
    const double below = static_cast<double>(vx.lo[a]) - p(a);
    const double above = p(a) - static_cast<double>(vx.hi[a]);
    box[a] = below > 0.0 ? below : (above > 0.0 ? above : 0.0);
  }
  if (box[0] * box[0] + (box[1] * box[1] + box[2] * box[2]) >= d2) return;
  const MapPoint* pts = map_[active_] + vx.begin;
  for (std::uint32_t i = 0; i < vx.count; ++i) {  // count <= max_per_voxel_
    const double dx = static_cast<double>(pts[i].x) - p.x();
    const double dx2 = dx * dx;
    if (dx2 >= d2) continue;
    const double dy = static_cast<double>(pts[i].y) - p.y();
    const double dz = static_cast<double>(pts[i].z) - p.z();
    const double d = dx2 + (dy * dy + dz * dz);
    if (d < d2) {
      d2 = d;
      best = &pts[i];
    }
  }
}

void OdometryVoxelMap::update(std::span<const Vec3f> frame, const Mat4d& pose, double max_range,
                              std::uint32_t& dropped, std::uint32_t& evicted) {
  // 1. Assign each new point to a voxel (existing or new), bounded by the per-voxel and total
  //    capacities.
  const std::size_t n = std::min(frame.size(), config::kMaxDownsampledPoints);
  dropped += static_cast<std::uint32_t>(frame.size() - n);
  std::size_t total = num_points_;
  for (std::size_t i = 0; i < n; ++i) {
    frame_voxel_[i] = kNone;
    const Vec3d p = transform(pose, frame[i]);
    std::int32_t key[3];
    if (!voxel_key(p, key)) {
      ++dropped;
      continue;
    }
    std::uint32_t v = find_voxel(key);
    // A full map takes no new voxel: it would stay empty, be evicted below and cost a re-index.
    if (v == kNone && total < kMaxPoints) v = insert_voxel(key);
    if (v == kNone) {
      ++dropped;
      continue;
    }
    Voxel& vx = voxels_[v];
    if (vx.count + vx.pending >= max_per_voxel_) continue;  // voxel full: normal, not a drop
    if (total == kMaxPoints) {
      ++dropped;
      continue;
    }
    ++vx.pending;
    ++total;
    frame_voxel_[i] = v;
  }
  // 2. Compact into the other buffer, evicting voxels whose centre is beyond max_range. Voxel
  //    indices (and so the hash index) change only when a voxel goes.
  const Vec3d origin = pose.topRightCorner<3, 1>();
  const double r2 = max_range * max_range;
  const int next = 1 - active_;
  std::uint32_t cursor = 0;
  std::size_t kept = 0;
  Run run;  // consecutive kept voxels without new points: one copy
  for (std::size_t v = 0; v < num_voxels_; ++v) {
    const Voxel vx = voxels_[v];  // compacted in place: kept <= v
    const Vec3d centre((vx.key[0] + 0.5) * voxel_size_, (vx.key[1] + 0.5) * voxel_size_,
                       (vx.key[2] + 0.5) * voxel_size_);
    if ((centre - origin).squaredNorm() > r2 || vx.count + vx.pending == 0) {
      ++evicted;
      slots_[vx.slot] = 0;  // the index is rebuilt below
      remap_[v] = kNone;
      continue;
    }
    Voxel& out = voxels_[kept];
    out = vx;
    out.begin = cursor;
    out.pending = 0;
    if (run.from + run.count != vx.begin || run.to + run.count != cursor) {
      copy_run(run, next);
      run = Run{vx.begin, cursor, 0};
    }
    run.count += vx.count;
    cursor += vx.count + vx.pending;
    remap_[v] = static_cast<std::uint32_t>(kept);
    ++kept;
  }
  copy_run(run, next);
  // 3. Append the new points in input order.
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t v = frame_voxel_[i];
    if (v == kNone || remap_[v] == kNone) continue;
    Voxel& out = voxels_[remap_[v]];
    const Vec3f m = transform(pose, frame[i]).cast<float>();
    map_[next][out.begin + out.count] = MapPoint{m.x(), m.y(), m.z()};
    ++out.count;
    V2XLOC_UNROLL_AXES for (int a = 0; a < 3; ++a) {
      out.lo[a] = std::min(out.lo[a], m[a]);
      out.hi[a] = std::max(out.hi[a], m[a]);
    }
  }
  // Voxel indices changed only if one went: then the index is rebuilt over the kept voxels.
  const bool reindex = kept != num_voxels_;
  active_ = next;
  num_voxels_ = kept;
  num_points_ = cursor;
  if (reindex) {
    for (std::size_t v = 0; v < num_voxels_; ++v) slots_[voxels_[v].slot] = 0;
    rebuild_index();
  }
}

void OdometryVoxelMap::copy_run(const Run& run, int next) {
  if (run.count > 0) std::memcpy(map_[next] + run.to, map_[active_] + run.from, run.count * sizeof(MapPoint));
}

void OdometryVoxelMap::rebuild_index() {
  for (std::size_t v = 0; v < num_voxels_; ++v) {
    Voxel& vx = voxels_[v];
    // The table holds at most kMaxPoints <= kSlots voxels; probing beyond the cap would only
    // happen for a pathological key set and then the voxel is unreachable (still counted in map).
    const ProbeResult probe = linear_probe(spatial_hash_folded(vx.key), kSlots, kMaxProbes,
                                           [&](std::size_t slot) { return slots_[slot] == 0; });
    if (probe.stopped) {
      slots_[probe.slot] = static_cast<std::uint32_t>(v + 1);
      vx.slot = static_cast<std::uint32_t>(probe.slot);
    } else {
      vx.slot = 0;  // unreachable voxel; slot 0 cleared harmlessly
    }
  }
}

}  // namespace v2xloc
