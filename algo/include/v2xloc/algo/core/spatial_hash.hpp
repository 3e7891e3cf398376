// The one spatial hash of the core: integer voxel keys hashed with Teschner et al. 2003
// ("Optimized Spatial Hashing for Collision Detection of Deformable Objects": three large primes,
// xor) into a power-of-two open-addressing table with bounded linear probing. Used by the voxel
// downsampler, the odometry's voxel map and the map fusion's occupancy cells; each keeps its own
// slot layout (what a slot stores differs) and calls linear_probe() to walk it.
#pragma once

#include <cstddef>
#include <cstdint>

namespace v2xloc {

// Teschner et al. 2003, eq. (1) without the modulo; unsigned arithmetic (wraps, no overflow UB).
// Xor-separable: the xor of spatial_hash_axis(0, x), (1, y) and (2, z), so a caller hashing a
// block of neighbour keys multiplies once per axis value, not once per key.
inline std::uint32_t spatial_hash_axis(int axis, std::int32_t v) {
  constexpr std::uint32_t kPrimes[3] = {73856093u, 19349669u, 83492791u};
  return static_cast<std::uint32_t>(v) * kPrimes[axis];
}
inline std::uint32_t spatial_hash(std::int32_t x, std::int32_t y, std::int32_t z) {
  return spatial_hash_axis(0, x) ^ spatial_hash_axis(1, y) ^ spatial_hash_axis(2, z);
}
inline std::uint32_t spatial_hash(const std::int32_t key[3]) { return spatial_hash(key[0], key[1], key[2]); }

// The hash with its high half folded into the low bits, for tables indexed by the low bits of a
// small mask (the downsampler's, the scan ingest's, the odometry's): bit k of the plain hash
// depends only on bits <= k of the keys, so neighbouring keys crowd a few probe chains.
inline std::uint32_t spatial_hash_folded(std::int32_t x, std::int32_t y, std::int32_t z) {
  const std::uint32_t h = spatial_hash(x, y, z);
  return h ^ (h >> 16);
}
inline std::uint32_t spatial_hash_folded(const std::int32_t key[3]) { return spatial_hash_folded(key[0], key[1], key[2]); }

struct ProbeResult {
  bool stopped = false;     // visit() returned true at slot `slot`
  std::uint32_t probes = 0; // index of that probe if stopped, else the number of slots visited
  std::size_t slot = 0;
};

// Linear probing over a table of num_slots (a power of two) starting at hash & (num_slots - 1):
// calls visit(slot) for at most max_probes consecutive slots until it returns true.
template <class Visit>
ProbeResult linear_probe(std::uint32_t hash, std::size_t num_slots, std::uint32_t max_probes, Visit&& visit) {
  const std::size_t mask = num_slots - 1;
  ProbeResult r;
  std::size_t s = hash & mask;
  for (; r.probes < max_probes; ++r.probes, s = (s + 1) & mask) {
    if (visit(s)) {
      r.stopped = true;
      r.slot = s;
      return r;
    }
  }
  return r;
}

// Tables whose slots hold an item index + 1 (0 = empty) over items that carry their `key[3]`
// (the odometry's map voxels and coarse frame voxels, placed by spatial_hash_folded): the index of the item with this key, or
// kNoItem when a probe reaches an empty slot or max_probes first.
inline constexpr std::uint32_t kNoItem = 0xFFFFFFFFu;
template <class Item>
std::uint32_t find_indexed(const std::uint32_t* slots, std::size_t num_slots, std::uint32_t max_probes,
                           const Item* items, const std::int32_t key[3]) {
  std::uint32_t found = kNoItem;
  linear_probe(spatial_hash_folded(key), num_slots, max_probes, [&](std::size_t slot) {
    const std::uint32_t v = slots[slot];
    if (v == 0) return true;
    const Item& item = items[v - 1];
    if (item.key[0] == key[0] && item.key[1] == key[1] && item.key[2] == key[2]) {
      found = v - 1;
      return true;
    }
    return false;
  });
  return found;
}

}  // namespace v2xloc
