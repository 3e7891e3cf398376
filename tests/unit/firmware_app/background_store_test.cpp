// The firmware's surveyed-background store: each file the trust list vouches for is kept in its
// unit's static slot and handed to the localizer once; a refused file keeps nothing; the store
// is bounded by config::kMaxBackgroundUnits.
#include "firmware/wire/background_store.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

namespace v2xloc::firmware {
namespace {

// Infrastructure signer `id` whose trust-list entry vouches for `file`.
trust::TrustedSigner signer_for(std::uint32_t id, const std::vector<std::uint8_t>& file) {
  trust::TrustedSigner s;
  s.role = trust::SignerRole::kInfrastructure;
  s.sender_id = id;
  s.has_background = true;
  s.background_sha256 = trust::sha256(file);
  return s;
}

std::vector<std::uint8_t> file_for(std::uint32_t id, std::size_t n) {
  std::vector<std::uint32_t> keys(n);
  for (std::size_t i = 0; i < n; ++i) keys[i] = static_cast<std::uint32_t>(10 * i + id);
  std::vector<std::uint8_t> out(trust::background_file_bytes(n));
  trust::format_background(id, 250'000, keys, out);
  return out;
}

// Records what the store hands over (the Localizer's set_background signature).
struct FakeLocalizer {
  std::vector<std::uint32_t> ids;
  std::vector<SurveyedBackground> backgrounds;
  bool set_background(std::uint32_t id, const SurveyedBackground& b) {
    ids.push_back(id);
    backgrounds.push_back(b);
    return background_valid(b);
  }
};

TEST(BackgroundStore, KeepsCheckedFilesAndHandsThemOverOnce) {
  auto store = std::make_unique<BackgroundStore>();  // ~1 MB host
  const std::vector<std::uint8_t> a = file_for(1, 50), b = file_for(3, 70);
  ASSERT_EQ(store->load(signer_for(1, a), a), trust::BackgroundStatus::kOk);
  std::vector<std::uint8_t> tampered = b;
  tampered.back() ^= 0x80;
  EXPECT_EQ(store->load(signer_for(3, b), tampered), trust::BackgroundStatus::kDigestMismatch);
  EXPECT_EQ(store->count(), 1u);  // nothing kept of the refused file
  ASSERT_EQ(store->load(signer_for(3, b), b), trust::BackgroundStatus::kOk);
  FakeLocalizer localizer;
  EXPECT_EQ(store->provision(localizer), 2u);
  ASSERT_EQ(localizer.ids.size(), 2u);
  EXPECT_EQ(localizer.ids[0], 1u);
  EXPECT_EQ(localizer.ids[1], 3u);
  EXPECT_DOUBLE_EQ(localizer.backgrounds[1].cell, 0.25);
  ASSERT_EQ(localizer.backgrounds[1].cells.size(), 70u);
  EXPECT_EQ(localizer.backgrounds[1].cells[69], 693u);
}

TEST(BackgroundStore, IsBoundedByTheUnitCapacity) {
  auto store = std::make_unique<BackgroundStore>();
  for (std::uint32_t id = 1; id <= BackgroundStore::kUnits; ++id) {
    const std::vector<std::uint8_t> f = file_for(id, 4);
    ASSERT_EQ(store->load(signer_for(id, f), f), trust::BackgroundStatus::kOk);
  }
  EXPECT_TRUE(store->full());
  const std::vector<std::uint8_t> f = file_for(99, 4);
  EXPECT_EQ(store->load(signer_for(99, f), f), trust::BackgroundStatus::kBadCount);
  EXPECT_EQ(store->count(), BackgroundStore::kUnits);
}

}  // namespace
}  // namespace v2xloc::firmware
