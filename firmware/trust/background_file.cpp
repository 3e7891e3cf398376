#include "firmware/trust/background_file.hpp"

#include <cstring>

namespace v2xloc::trust {
namespace {

constexpr char kMagic[8] = {'V', '2', 'X', 'L', 'O', 'C', 'B', 'G'};

std::uint32_t read_u32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

void write_u32(std::uint8_t* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

}  // namespace

const char* to_string(BackgroundStatus s) {
  switch (s) {
    case BackgroundStatus::kOk: return "ok";
    case BackgroundStatus::kNoBackground: return "the trust list names no background for this signer";
    case BackgroundStatus::kTooLarge: return "background file too large";
    case BackgroundStatus::kBadSize: return "background file size is not header + 4 bytes per cell";
    case BackgroundStatus::kDigestMismatch: return "background file SHA-256 differs from the trust list's";
    case BackgroundStatus::kBadMagic: return "not a background file (magic V2XLOCBG)";
    case BackgroundStatus::kBadVersion: return "unsupported background file version";
    case BackgroundStatus::kWrongSender: return "background file is for another sender id";
    case BackgroundStatus::kBadCell: return "background cell edge outside 0.02-2 m";
    case BackgroundStatus::kBadCount: return "background cell count 0 or over the firmware's capacity";
    case BackgroundStatus::kNotAscending: return "background cells not strictly ascending";
  }
  return "?";
}

BackgroundStatus parse_background(std::span<const std::uint8_t> bytes, const TrustedSigner& signer,
                                  std::span<std::uint32_t> cells, BackgroundInfo& info) {
  info = BackgroundInfo{};
  if (!signer.has_background) return BackgroundStatus::kNoBackground;
  if (bytes.size() > kMaxBackgroundFileBytes) return BackgroundStatus::kTooLarge;
  if (bytes.size() < kBackgroundHeaderBytes || (bytes.size() - kBackgroundHeaderBytes) % 4 != 0) {
    return BackgroundStatus::kBadSize;
  }
  if (sha256(bytes) != signer.background_sha256) return BackgroundStatus::kDigestMismatch;
  const std::uint8_t* p = bytes.data();
  if (std::memcmp(p, kMagic, sizeof kMagic) != 0) return BackgroundStatus::kBadMagic;
  if (read_u32(p + 8) != kBackgroundVersion) return BackgroundStatus::kBadVersion;
  if (read_u32(p + 12) != signer.sender_id) return BackgroundStatus::kWrongSender;
  const std::uint32_t cell_um = read_u32(p + 16);
  if (cell_um < kBackgroundMinCellUm || cell_um > kBackgroundMaxCellUm) return BackgroundStatus::kBadCell;
  const std::uint32_t n = read_u32(p + 20);
  if (n == 0 || n > cells.size()) return BackgroundStatus::kBadCount;
  if (bytes.size() != background_file_bytes(n)) return BackgroundStatus::kBadSize;
  for (std::uint32_t i = 0; i < n; ++i) {
    cells[i] = read_u32(p + kBackgroundHeaderBytes + 4 * static_cast<std::size_t>(i));
    if (i > 0 && !(cells[i - 1] < cells[i])) return BackgroundStatus::kNotAscending;
  }
  info.sender_id = signer.sender_id;
  info.cell_m = static_cast<double>(cell_um) * 1e-6;
  info.cells = n;
  return BackgroundStatus::kOk;
}

std::size_t format_background(std::uint32_t sender_id, std::uint32_t cell_um, std::span<const std::uint32_t> keys,
                              std::span<std::uint8_t> out) {
  const std::size_t size = background_file_bytes(keys.size());
  if (keys.empty() || size > out.size() || size > kMaxBackgroundFileBytes || cell_um < kBackgroundMinCellUm ||
      cell_um > kBackgroundMaxCellUm) {
    return 0;
  }
  std::uint8_t* p = out.data();
  std::memcpy(p, kMagic, sizeof kMagic);
  write_u32(p + 8, kBackgroundVersion);
  write_u32(p + 12, sender_id);
  write_u32(p + 16, cell_um);
  write_u32(p + 20, static_cast<std::uint32_t>(keys.size()));
  for (std::size_t i = 0; i < keys.size(); ++i) write_u32(p + kBackgroundHeaderBytes + 4 * i, keys[i]);
  return size;
}

}  // namespace v2xloc::trust
