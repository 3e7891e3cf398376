// Surveyed background files: an infrastructure unit's static scene as voxel cells in its sensor
// frame (algo/.../surveyed_background.hpp), named by the unit's `background` line in the trust
// list together with the file's SHA-256, so the provisioned trust list vouches for the bytes.
//
// Binary, little-endian, exactly kBackgroundHeaderBytes + 4 n bytes:
//   0   8  magic "V2XLOCBG"
//   8   4  version (1)
//   12  4  sender id (must be the trust-list signer's)
//   16  4  cell edge in micrometres, [20,000, 2,000,000] (0.02-2 m)
//   20  4  n, cell count, 1..capacity
//   24  4n packed cell keys (background_cell_key), strictly ascending
// parse_background() is a pure function over bytes (fuzzed): sizes are checked before anything is
// read, the digest before the contents, and every refusal has its own status.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/trust/trust_list.hpp"

namespace v2xloc::trust {

inline constexpr std::size_t kBackgroundHeaderBytes = 24;
inline constexpr std::uint32_t kBackgroundVersion = 1;
inline constexpr std::uint32_t kBackgroundMinCellUm = 20'000;
inline constexpr std::uint32_t kBackgroundMaxCellUm = 2'000'000;
// The format's bound (65,536 cells, 256 KiB); a reader refuses more before reading it. A profile's
// own capacity is the storage its caller passes (algo config::kMaxBackgroundCells).
inline constexpr std::size_t kMaxBackgroundFileBytes = kBackgroundHeaderBytes + 4 * 65536;

enum class BackgroundStatus : std::uint8_t {
  kOk,
  kNoBackground,   // the signer's trust-list entry names no background
  kTooLarge,       // more bytes than kMaxBackgroundFileBytes
  kBadSize,        // shorter than the header, or not header + 4 n bytes
  kDigestMismatch, // SHA-256 differs from the trust list's
  kBadMagic,
  kBadVersion,
  kWrongSender,    // the file's sender id is not the signer's
  kBadCell,        // cell edge outside [kBackgroundMinCellUm, kBackgroundMaxCellUm]
  kBadCount,       // n = 0 or more than the caller's storage holds
  kNotAscending,   // keys not strictly ascending
};
const char* to_string(BackgroundStatus s);

struct BackgroundInfo {
  std::uint32_t sender_id = 0;
  double cell_m = 0.0;
  std::size_t cells = 0;  // keys written to the front of the caller's storage
};

// Checks `bytes` against `signer` (its background digest and sender id) and copies the keys into
// `cells` (capacity = its size). Nothing in `info` is valid unless kOk.
BackgroundStatus parse_background(std::span<const std::uint8_t> bytes, const TrustedSigner& signer,
                                  std::span<std::uint32_t> cells, BackgroundInfo& info);

// Bytes of a file with n cells, and the file itself (host tools: returns bytes written, 0 when
// `out` is too small or a value is out of the format's range; keys are written as given).
inline constexpr std::size_t background_file_bytes(std::size_t n) { return kBackgroundHeaderBytes + 4 * n; }
std::size_t format_background(std::uint32_t sender_id, std::uint32_t cell_um, std::span<const std::uint32_t> keys,
                              std::span<std::uint8_t> out);

}  // namespace v2xloc::trust
