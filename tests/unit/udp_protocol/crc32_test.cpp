#include "firmware/protocol/crc32.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

namespace v2xloc::protocol {
namespace {

std::span<const std::uint8_t> bytes_of(const char* s) {
  return {reinterpret_cast<const std::uint8_t*>(s), std::strlen(s)};
}

TEST(Crc32, MatchesTheIeeeCheckValue) {
  EXPECT_EQ(crc32(bytes_of("123456789")), 0xCBF43926u);  // catalogue check value of CRC-32/ISO-HDLC
  EXPECT_EQ(crc32(bytes_of("")), 0x00000000u);
  EXPECT_EQ(crc32(bytes_of("The quick brown fox jumps over the lazy dog")), 0x414FA339u);
}

TEST(Crc32, ChainedUpdatesEqualOneShot) {
  const auto all = bytes_of("123456789");
  const std::uint32_t chained = crc32_update(crc32_update(0u, all.first(4)), all.subspan(4));
  EXPECT_EQ(chained, crc32(all));
}

// The byte-at-a-time table loop crc32_update() used before slicing-by-8: the reference.
std::uint32_t bytewise_crc32(std::uint32_t crc, std::span<const std::uint8_t> bytes) {
  std::uint32_t table[256];
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  std::uint32_t c = crc ^ 0xFFFFFFFFu;
  for (const std::uint8_t b : bytes) c = table[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

TEST(Crc32, SlicingByEightEqualsTheBytewiseLoop) {
  std::mt19937 rng(13);
  std::vector<std::uint8_t> buffer(4096);
  for (auto& b : buffer) b = static_cast<std::uint8_t>(rng());
  const std::span<const std::uint8_t> all(buffer);
  // Every length and start offset (alignment) around the 8-byte blocks, then random slices.
  for (std::size_t offset = 0; offset < 16; ++offset) {
    for (std::size_t n = 0; n <= 80; ++n) {
      ASSERT_EQ(crc32(all.subspan(offset, n)), bytewise_crc32(0u, all.subspan(offset, n))) << offset << " " << n;
    }
  }
  for (int k = 0; k < 2000; ++k) {
    const std::size_t offset = rng() % 64, n = rng() % (buffer.size() - 64);
    const std::uint32_t seed = rng();
    ASSERT_EQ(crc32_update(seed, all.subspan(offset, n)), bytewise_crc32(seed, all.subspan(offset, n)));
  }
  const std::vector<std::uint8_t> ones(1400, 0xFF), zeros(1400, 0x00);
  EXPECT_EQ(crc32(ones), bytewise_crc32(0u, ones));
  EXPECT_EQ(crc32(zeros), bytewise_crc32(0u, zeros));
}

}  // namespace
}  // namespace v2xloc::protocol
