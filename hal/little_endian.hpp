// Little-endian byte packing for every wire format of the house (point-cloud datagrams, the HID
// IMU report, the emulated sim-time CAN frame): byte by byte, so the bytes are the same on little-
// and big-endian hosts. CAN signals use the DBC bit packing instead (algo/core/det_math.hpp).
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>

namespace v2xloc::hal::le {

template <class Unsigned>
constexpr void put(std::uint8_t* p, Unsigned v) {
  for (std::size_t i = 0; i < sizeof(Unsigned); ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
template <class Unsigned>
constexpr Unsigned get(const std::uint8_t* p) {
  Unsigned v = 0;
  for (std::size_t i = sizeof(Unsigned); i-- > 0;) v = static_cast<Unsigned>((v << 8) | p[i]);
  return v;
}

constexpr void put_u8(std::uint8_t* p, std::uint8_t v) { p[0] = v; }
constexpr void put_u16(std::uint8_t* p, std::uint16_t v) { put(p, v); }
constexpr void put_u32(std::uint8_t* p, std::uint32_t v) { put(p, v); }
constexpr void put_u64(std::uint8_t* p, std::uint64_t v) { put(p, v); }
constexpr void put_f32(std::uint8_t* p, float v) { put(p, std::bit_cast<std::uint32_t>(v)); }
constexpr void put_f64(std::uint8_t* p, double v) { put(p, std::bit_cast<std::uint64_t>(v)); }

constexpr std::uint16_t get_u16(const std::uint8_t* p) { return get<std::uint16_t>(p); }
constexpr std::uint32_t get_u32(const std::uint8_t* p) { return get<std::uint32_t>(p); }
constexpr std::uint64_t get_u64(const std::uint8_t* p) { return get<std::uint64_t>(p); }
constexpr float get_f32(const std::uint8_t* p) { return std::bit_cast<float>(get_u32(p)); }
constexpr double get_f64(const std::uint8_t* p) { return std::bit_cast<double>(get_u64(p)); }

}  // namespace v2xloc::hal::le
