// Which map sources occupy which cells, kept across map inserts (map fusion's consistency
// reference). Each cell of a grid holds one bit per source slot; a source's bits are set when its
// cloud is stored and cleared when it is removed, so a consistency check only looks cells up
// instead of re-marking every other source's points per cloud (that re-marking was ~40 % of a
// check: ~8 M instructions per cloud with four infrastructure units in the map).
// Several grids share the table: the grid's level sits in the low two bits of the z key.
// Cells whose last bit is cleared stay in their probe chain (open addressing); once live and empty
// cells fill half the table (EMBEDDED three quarters) the owner rebuilds it from its points
// (needs_rebuild(); at half, a 12,288-point EMBEDDED map's first two clouds already rebuilt it within
// the power-up period, 6.5 M instructions on the R52). A cell that
// finds no slot within config::kVoxelMaxProbes probes is not recorded and counted (dropped()).
// Most lookups are of absent cells (a consistency check asks for the 27 cells around a point); a
// bitmap of the hashes ever added answers most of those without walking a probe chain.
#pragma once

#include <cstddef>
#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

class SourceCells {
 public:
  using Mask = std::uint16_t;
  static_assert(config::kMaxMapSources <= 16, "one bit per source slot in a 16-bit mask");
  static constexpr std::size_t kSlots = config::kMapReferenceCellSlots;
  static_assert((kSlots & (kSlots - 1)) == 0, "hash slots must be a power of two");

  // Cell key of p on the grid of size `cell` at `level` (0-3); false when p is too far out for
  // a key (|p / cell| >= 2^28, or non-finite).
  static bool cell_key(const Vec3f& p, double cell, std::int32_t level, std::int32_t key[3]);

  static constexpr std::uint32_t kNoCell = 0xFFFFFFFFu;

  void clear();
  // Sets `bits` in the cell of key (adds the cell); returns its slot, or kNoCell when no slot was
  // found (counted). The slot stays the cell's until clear(): the owner may keep it for remove_at.
  std::uint32_t add(const std::int32_t key[3], Mask bits);
  // Clears `bits` in the cell at a slot add() returned (kNoCell: nothing).
  void remove_at(std::uint32_t slot, Mask bits) {
    if (slot < kSlots) cells_[slot].bits = static_cast<Mask>(cells_[slot].bits & ~bits);
  }
  // Sets `bits` again in the cell at a slot add() returned (kNoCell: nothing): the cell keeps its
  // key and slot until clear().
  void set_at(std::uint32_t slot, Mask bits) {
    if (slot < kSlots) cells_[slot].bits = static_cast<Mask>(cells_[slot].bits | bits);
  }
  // Bits of the cell (0 when absent).
  Mask bits(const std::int32_t key[3]) const;
  // Any of `allowed` in the 27 cells around p's cell on that grid.
  bool any_around(const Vec3f& p, double cell, std::int32_t level, Mask allowed) const;

  static constexpr std::size_t kRebuildQuarters = config::kMapReferenceCellRebuildQuarters;
  static_assert(kRebuildQuarters >= 1 && kRebuildQuarters <= 3, "a rebuild before the table fills");
  bool needs_rebuild() const { return used_ * 4 >= kSlots * kRebuildQuarters; }
  std::size_t used_cells() const { return used_; }
  std::uint64_t dropped() const { return dropped_; }

 private:
  struct Cell {
    std::int32_t key[3];
    Mask bits;
    std::uint16_t used;  // 1 once claimed by a key (stays in the probe chain when bits go to 0)
  };
  // Slot of key, or kSlots when absent.
  std::size_t find(const std::int32_t key[3]) const;
  // Slot of key by walking its probe chain (hash == spatial_hash(key)), or kSlots.
  std::size_t probe(std::uint32_t hash, const std::int32_t key[3]) const;
  // False proves the key of this hash was never added.
  bool seen(std::uint32_t hash) const {
    const std::size_t bit = seen_bit(hash);
    return ((seen_[bit / 64] >> (bit % 64)) & 1u) != 0;
  }
  // One bit per hash value modulo kSeenBits, set by add() until clear(): a clear bit proves the
  // key absent. 8 bits per slot: at most 3/4 of the slots are used, so >= 29/32 of the bits are
  // clear. A set bit of an absent key walks the probe chain to its end, long at 3/4 load: with 4
  // bits per slot those walks were most of the probes and map fusion's consistency check cost 10 %
  // more (x86-64, EMBEDDED, Sim 3 / 4_infra_2_agent; algo/TUNING.md).
  static constexpr std::size_t kSeenBits = 8 * kSlots;
  static std::size_t seen_bit(std::uint32_t hash) { return hash & (kSeenBits - 1); }

  Cell cells_[kSlots] = {};
  std::uint64_t seen_[kSeenBits / 64] = {};
  std::size_t used_ = 0;
  std::uint64_t dropped_ = 0;
};

}  // namespace v2xloc
