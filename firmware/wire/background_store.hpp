// The surveyed backgrounds the trust list names (firmware/trust/background_file.hpp), loaded once
// at start into static storage and handed to the localizer, which reads them for as long as it
// runs: kMaxBackgroundUnits x kMaxBackgroundCells packed cells (config.hpp; EMBEDDED 128 KiB).
// No allocation; loading is a pure copy of checked bytes, the file I/O is the caller's.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/trust/background_file.hpp"
#include "firmware/trust/trust_list.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/surveyed_background.hpp"

namespace v2xloc::firmware {

class BackgroundStore {
 public:
  static constexpr std::size_t kUnits = config::kMaxBackgroundUnits;
  static constexpr std::size_t kCells = config::kMaxBackgroundCells;

  bool full() const { return count_ == kUnits; }
  std::size_t count() const { return count_; }
  // Checks `bytes` against the signer's trust-list entry and keeps them as the next unit's
  // background (kOk), else nothing is kept. Full: kBadCount (check full() first for a clear message).
  trust::BackgroundStatus load(const trust::TrustedSigner& signer, std::span<const std::uint8_t> bytes);
  std::uint32_t sender_id(std::size_t i) const { return units_[i].sender_id; }
  SurveyedBackground background(std::size_t i) const {
    return SurveyedBackground{units_[i].cell_m, std::span<const std::uint32_t>(cells_[i], units_[i].cells)};
  }
  // Hands every loaded background to the localizer (after its configure()); returns how many it
  // took (all, unless one is not valid for the algorithm: a bug, reported by the caller).
  template <class LocalizerT>
  std::size_t provision(LocalizerT& localizer) const {
    std::size_t taken = 0;
    for (std::size_t i = 0; i < count_; ++i) taken += localizer.set_background(units_[i].sender_id, background(i)) ? 1u : 0u;
    return taken;
  }

 private:
  struct Unit {
    std::uint32_t sender_id = 0;
    double cell_m = 0.0;
    std::size_t cells = 0;
  };
  std::uint32_t cells_[kUnits][kCells];
  Unit units_[kUnits]{};
  std::size_t count_ = 0;
};

}  // namespace v2xloc::firmware
