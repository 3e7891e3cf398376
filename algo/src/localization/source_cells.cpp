#include "v2xloc/algo/localization/source_cells.hpp"

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/spatial_hash.hpp"
#include "v2xloc/algo/core/unroll.hpp"

namespace v2xloc {

namespace {
constexpr auto kMaxProbes = static_cast<std::uint32_t>(config::kVoxelMaxProbes);
}  // namespace

bool SourceCells::cell_key(const Vec3f& p, double cell, std::int32_t level, std::int32_t key[3]) {
  V2XLOC_UNROLL_AXES for (int i = 0; i < 3; ++i) {
    const double q = static_cast<double>(p(i)) / cell;
    if (!(q > -268435456.0 && q < 268435456.0)) return false;  // 2^28: z keeps 2 level bits
    key[i] = det::floor_to_int(q);
    if (key[i] == -268435456) return false;  // floor(q) must stay above -2^28 as well
  }
  key[2] = key[2] * 4 + level;
  return true;
}

void SourceCells::clear() {
  for (Cell& c : cells_) c = Cell{};
  for (std::uint64_t& w : seen_) w = 0;
  used_ = 0;
}

std::size_t SourceCells::find(const std::int32_t key[3]) const {
  const std::uint32_t hash = spatial_hash(key);
  return seen(hash) ? probe(hash, key) : kSlots;
}

std::size_t SourceCells::probe(std::uint32_t hash, const std::int32_t key[3]) const {
  std::size_t found = kSlots;
  linear_probe(hash, kSlots, kMaxProbes, [&](std::size_t slot) {
    const Cell& c = cells_[slot];
    if (!c.used) return true;
    if (c.key[0] == key[0] && c.key[1] == key[1] && c.key[2] == key[2]) {
      found = slot;
      return true;
    }
    return false;
  });
  return found;
}

std::uint32_t SourceCells::add(const std::int32_t key[3], Mask bits) {
  const std::uint32_t hash = spatial_hash(key);
  const std::size_t bit = seen_bit(hash);
  seen_[bit / 64] |= std::uint64_t{1} << (bit % 64);
  const ProbeResult r = linear_probe(hash, kSlots, kMaxProbes, [&](std::size_t slot) {
    Cell& c = cells_[slot];
    if (!c.used) {
      c.key[0] = key[0];
      c.key[1] = key[1];
      c.key[2] = key[2];
      c.used = 1;
      c.bits = 0;
      ++used_;
    } else if (!(c.key[0] == key[0] && c.key[1] == key[1] && c.key[2] == key[2])) {
      return false;
    }
    c.bits = static_cast<Mask>(c.bits | bits);
    return true;
  });
  if (!r.stopped) ++dropped_;
  return r.stopped ? static_cast<std::uint32_t>(r.slot) : kNoCell;
}

SourceCells::Mask SourceCells::bits(const std::int32_t key[3]) const {
  const std::size_t slot = find(key);
  return slot < kSlots ? cells_[slot].bits : Mask{0};
}

// The 27 hashes come from 9 per-axis products (spatial_hash is xor-separable); most cells around
// a point were never added, and the seen bitmap turns those away before any probe. The answer
// does not depend on the order the cells are asked in: p's own cell and its row come first (offset
// 0, then -1, +1 per axis), where a point on another source's surface usually finds one at once.
bool SourceCells::any_around(const Vec3f& p, double cell, std::int32_t level, Mask allowed) const {
  std::int32_t key[3];
  if (!cell_key(p, cell, level, key)) return false;
  static constexpr std::int32_t kOffsets[3] = {0, -1, 1};
  std::uint32_t hx[3], hy[3], hz[3];
  for (int d = 0; d < 3; ++d) {
    hx[d] = spatial_hash_axis(0, key[0] + kOffsets[d]);
    hy[d] = spatial_hash_axis(1, key[1] + kOffsets[d]);
    hz[d] = spatial_hash_axis(2, key[2] + 4 * kOffsets[d]);  // z carries the level in its low two bits
  }
  for (int dx = 0; dx < 3; ++dx)
    for (int dy = 0; dy < 3; ++dy) {
      const std::uint32_t hxy = hx[dx] ^ hy[dy];
      for (int dz = 0; dz < 3; ++dz) {
        const std::uint32_t hash = hxy ^ hz[dz];
        if (!seen(hash)) continue;
        const std::int32_t k[3] = {key[0] + kOffsets[dx], key[1] + kOffsets[dy], key[2] + 4 * kOffsets[dz]};
        const std::size_t slot = probe(hash, k);
        if (slot < kSlots && (cells_[slot].bits & allowed) != 0) return true;
      }
    }
  return false;
}

}  // namespace v2xloc
