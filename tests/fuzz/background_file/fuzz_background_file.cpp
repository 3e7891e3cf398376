// Surveyed background files (firmware/trust/background_file.hpp) from arbitrary bytes, checked
// against a trust-list entry that vouches for exactly these bytes (so the parser gets past the
// digest): a file parses or is refused with a named status and leaves nothing claimed; one that
// parses holds 1..capacity strictly ascending keys, a cell within the format's range and the
// signer's sender id, and formats back to the same bytes. The same bytes under another digest
// are always refused.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "firmware/trust/background_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::trust;
  const std::span<const std::uint8_t> bytes(data, size);
  TrustedSigner signer;
  signer.role = SignerRole::kInfrastructure;
  signer.sender_id = size >= 16 ? static_cast<std::uint32_t>(data[12]) | (static_cast<std::uint32_t>(data[13]) << 8) |
                                      (static_cast<std::uint32_t>(data[14]) << 16) |
                                      (static_cast<std::uint32_t>(data[15]) << 24)
                                : 1u;
  signer.has_background = true;
  signer.background_sha256 = sha256(bytes);
  std::vector<std::uint32_t> cells(8192);  // the simulator's files fit; inputs can exceed it
  BackgroundInfo info;
  const BackgroundStatus s = parse_background(bytes, signer, cells, info);
  if (to_string(s) == nullptr || std::strcmp(to_string(s), "?") == 0) std::abort();
  if (s != BackgroundStatus::kOk) {
    if (info.cells != 0) std::abort();
  } else {
    if (info.cells == 0 || info.cells > cells.size() || info.sender_id != signer.sender_id) std::abort();
    if (!(info.cell_m >= 0.02 - 1e-12 && info.cell_m <= 2.0 + 1e-12)) std::abort();
    for (std::size_t i = 1; i < info.cells; ++i) {
      if (!(cells[i - 1] < cells[i])) std::abort();
    }
    std::vector<std::uint8_t> again(background_file_bytes(info.cells));
    const auto cell_um = static_cast<std::uint32_t>(data[16]) | (static_cast<std::uint32_t>(data[17]) << 8) |
                         (static_cast<std::uint32_t>(data[18]) << 16) | (static_cast<std::uint32_t>(data[19]) << 24);
    if (format_background(info.sender_id, cell_um, {cells.data(), info.cells}, again) != size ||
        std::memcmp(again.data(), data, size) != 0)
      std::abort();
  }
  signer.background_sha256[0] ^= 1;  // the list vouches for other bytes
  if (parse_background(bytes, signer, cells, info) == BackgroundStatus::kOk) std::abort();
  return 0;
}
