#include "firmware/protocol/crc32.hpp"

#include <gtest/gtest.h>

#include <cstring>

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

}  // namespace
}  // namespace v2xloc::protocol
