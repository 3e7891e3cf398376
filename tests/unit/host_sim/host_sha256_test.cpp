// The replayer's SHA-256 (SHA extensions where the CPU has them) against the firmware's mbedTLS one.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "firmware/trust/p256.hpp"
#include "host_sim/replay/host_sha256.hpp"

namespace v2xloc::sim::replay {
namespace {

TEST(HostSha256, KnownAnswers) {
  const char* abc = "abc";
  const trust::Digest d = host_sha256({reinterpret_cast<const std::uint8_t*>(abc), 3});
  const std::uint8_t expected[32] = {0xba, 0x78, 0x16, 0xbf, 0x8f, 0x01, 0xcf, 0xea, 0x41, 0x41, 0x40,
                                     0xde, 0x5d, 0xae, 0x22, 0x23, 0xb0, 0x03, 0x61, 0xa3, 0x96, 0x17,
                                     0x7a, 0x9c, 0xb4, 0x10, 0xff, 0x61, 0xf2, 0x00, 0x15, 0xad};
  EXPECT_EQ(std::memcmp(d.data(), expected, 32), 0);
  std::printf("host_sha256: SHA extensions %s\n", host_sha256_accelerated() ? "used" : "not available");
}

TEST(HostSha256, EqualsTheFirmwareHashForEveryLengthAroundTheBlocks) {
  std::mt19937 rng(21);
  std::vector<std::uint8_t> bytes(4096);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
  const std::span<const std::uint8_t> all(bytes);
  for (std::size_t n = 0; n <= 300; ++n) {
    ASSERT_EQ(host_sha256(all.subspan(1, n)), trust::sha256(all.subspan(1, n))) << n;
  }
  for (int k = 0; k < 300; ++k) {
    const std::size_t offset = rng() % 16, n = rng() % (bytes.size() - 16);
    ASSERT_EQ(host_sha256(all.subspan(offset, n)), trust::sha256(all.subspan(offset, n))) << n;
  }
}

}  // namespace
}  // namespace v2xloc::sim::replay
