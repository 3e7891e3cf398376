#include "v2xloc/algo/localization/map_plane_cells.hpp"

#include <cmath>

#include "v2xloc/algo/core/spatial_hash.hpp"
#include "v2xloc/algo/core/symmetric_eigen.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);

bool same_key(const std::int32_t a[3], const std::int32_t b[3]) {
  return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}
}  // namespace

bool MapPlaneCells::key_of(const Vec3d& p, std::int32_t key[3]) const {
  for (int i = 0; i < 3; ++i) {
    const double k = std::floor(p(i) / cell_size_);
    if (!(k > -268435456.0 && k < 268435456.0)) return false;  // also false for NaN
    key[i] = static_cast<std::int32_t>(k);
  }
  return true;
}

MapPlaneCells::Cell* MapPlaneCells::find(const std::int32_t key[3]) {
  Cell* found = nullptr;
  linear_probe(spatial_hash(key), kSlots, kMaxProbes, [&](std::size_t slot) {
    Cell& c = cells_table_[slot];
    if (c.stamp != stamp_) return true;  // empty: not present
    if (!same_key(c.key, key)) return false;
    found = &c;
    return true;
  });
  return found;
}

const MapPlaneCells::Cell* MapPlaneCells::find(const std::int32_t key[3]) const {
  return const_cast<MapPlaneCells*>(this)->find(key);
}

MapPlaneCells::Cell* MapPlaneCells::find_or_add(const std::int32_t key[3]) {
  Cell* found = nullptr;
  linear_probe(spatial_hash(key), kSlots, kMaxProbes, [&](std::size_t slot) {
    Cell& c = cells_table_[slot];
    if (c.stamp == stamp_ && !same_key(c.key, key)) return false;
    if (c.stamp != stamp_) {
      c = Cell{};
      c.key[0] = key[0];
      c.key[1] = key[1];
      c.key[2] = key[2];
      c.stamp = stamp_;
      ++cells_;
    }
    found = &c;
    return true;
  });
  return found;
}

std::uint32_t MapPlaneCells::build(std::span<const Vec3f> points, double cell_size, std::uint32_t min_points,
                                   double max_flatness, double min_spread) {
  if (++stamp_ == 0) {  // generation wrap-around: clear once every 2^32 builds
    for (Cell& c : cells_table_) c.stamp = 0;
    stamp_ = 1;
  }
  cells_ = 0;
  cell_size_ = cell_size > 0.0 ? cell_size : 1.0;
  min_points_ = min_points < 3 ? 3 : min_points;
  max_flatness_ = max_flatness;
  min_spread_ = min_spread;
  std::uint32_t dropped = 0;
  for (const Vec3f& pf : points) {
    const Vec3d p = pf.cast<double>();
    std::int32_t key[3];
    Cell* c = key_of(p, key) ? find_or_add(key) : nullptr;
    if (c == nullptr) {
      ++dropped;
      continue;
    }
    const float r[3] = {static_cast<float>(p.x() - key[0] * cell_size_), static_cast<float>(p.y() - key[1] * cell_size_),
                        static_cast<float>(p.z() - key[2] * cell_size_)};
    ++c->count;
    for (int i = 0; i < 3; ++i) c->sum[i] += r[i];
    c->sq[0] += r[0] * r[0];
    c->sq[1] += r[0] * r[1];
    c->sq[2] += r[0] * r[2];
    c->sq[3] += r[1] * r[1];
    c->sq[4] += r[1] * r[2];
    c->sq[5] += r[2] * r[2];
  }
  return dropped;
}

void MapPlaneCells::fit(Cell& c) const {
  c.fit = 2;
  if (c.count < min_points_) return;
  const double n = c.count;
  const Vec3d m(c.sum[0] / n, c.sum[1] / n, c.sum[2] / n);
  Mat3d cov;
  cov << c.sq[0] / n, c.sq[1] / n, c.sq[2] / n, c.sq[1] / n, c.sq[3] / n, c.sq[4] / n, c.sq[2] / n, c.sq[4] / n,
      c.sq[5] / n;
  cov -= m * m.transpose();
  Vec3d lambda;
  Mat3d vectors;
  symmetric_eigen3(cov, lambda, vectors);
  if (!(lambda(1) >= min_spread_ * min_spread_) || !(lambda(0) <= max_flatness_ * lambda(1))) return;
  for (int i = 0; i < 3; ++i) {
    c.centroid[i] = static_cast<float>(m(i));
    c.normal[i] = static_cast<float>(vectors(i, 0));
  }
  c.fit = 1;
}

bool MapPlaneCells::occupied(const Vec3d& p) const {
  std::int32_t key[3];
  return key_of(p, key) && find(key) != nullptr;
}

int MapPlaneCells::occupancy(const Vec3d& p) const {
  std::int32_t key[3];
  const Cell* c = key_of(p, key) ? find(key) : nullptr;
  if (c == nullptr) return 0;
  const double n = c->count;
  const double vx = c->sq[0] / n - (c->sum[0] / n) * (c->sum[0] / n);
  const double vy = c->sq[3] / n - (c->sum[1] / n) * (c->sum[1] / n);
  const double vz = c->sq[5] / n - (c->sum[2] / n) * (c->sum[2] / n);
  return vz < 0.1 * (vx + vy) ? 1 : 2;
}

PlaneMatch MapPlaneCells::nearest_plane(const Vec3d& p) {
  PlaneMatch best;
  std::int32_t key[3];
  if (!key_of(p, key)) return best;
  std::int32_t side[3];  // the neighbour on the side of the cell the point is closest to
  for (int i = 0; i < 3; ++i) side[i] = p(i) - key[i] * cell_size_ < 0.5 * cell_size_ ? -1 : 1;
  for (int corner = 0; corner < 8; ++corner) {
    const std::int32_t k[3] = {key[0] + ((corner & 1) ? side[0] : 0), key[1] + ((corner & 2) ? side[1] : 0),
                               key[2] + ((corner & 4) ? side[2] : 0)};
    Cell* c = find(k);
    if (c == nullptr) continue;
    if (c->fit == 0) fit(*c);
    if (c->fit != 1) continue;
    const Vec3d normal(c->normal[0], c->normal[1], c->normal[2]);
    const Vec3d centroid(k[0] * cell_size_ + c->centroid[0], k[1] * cell_size_ + c->centroid[1],
                         k[2] * cell_size_ + c->centroid[2]);
    const double r = normal.dot(p - centroid);
    if (!best.found || std::abs(r) < std::abs(best.residual)) {
      best.found = true;
      best.normal = normal;
      best.residual = r;
    }
  }
  return best;
}

}  // namespace v2xloc
