#include "firmware/wire/background_store.hpp"

namespace v2xloc::firmware {

trust::BackgroundStatus BackgroundStore::load(const trust::TrustedSigner& signer, std::span<const std::uint8_t> bytes) {
  if (full()) return trust::BackgroundStatus::kBadCount;
  trust::BackgroundInfo info;
  const trust::BackgroundStatus s = trust::parse_background(bytes, signer, cells_[count_], info);
  if (s != trust::BackgroundStatus::kOk) return s;
  units_[count_++] = Unit{info.sender_id, info.cell_m, info.cells};
  return s;
}

}  // namespace v2xloc::firmware
