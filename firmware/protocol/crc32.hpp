// CRC-32 (IEEE 802.3 / zlib / PNG: reflected polynomial 0xEDB88320, init and final XOR 0xFFFFFFFF).
// Check value: crc32("123456789") == 0xCBF43926. Slicing-by-8, tables built at compile time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace v2xloc::protocol {

// Continue a running CRC: pass the previous return value as `crc` (start with 0).
std::uint32_t crc32_update(std::uint32_t crc, std::span<const std::uint8_t> bytes);

inline std::uint32_t crc32(std::span<const std::uint8_t> bytes) { return crc32_update(0u, bytes); }

}  // namespace v2xloc::protocol
