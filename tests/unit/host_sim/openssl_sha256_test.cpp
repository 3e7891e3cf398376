// The replayer signs map shares over OpenSSL's SHA-256 of each fragment payload; the firmware
// checks them with its own (trust::sha256, mbedTLS). Both must give the same digest for every
// length: empty, within one block, across the padding boundary and over many blocks.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "firmware/trust/p256.hpp"
#include "host_sim/replay/openssl_sha256.hpp"

namespace v2xloc::sim::replay {
namespace {

std::span<const std::uint8_t> bytes_of(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

trust::Digest from_hex(std::string_view hex) {
  trust::Digest d{};
  for (std::size_t i = 0; i < d.size(); ++i) {
    d[i] = static_cast<std::uint8_t>(std::stoul(std::string(hex.substr(2 * i, 2)), nullptr, 16));
  }
  return d;
}

// FIPS 180-2 appendix B and the empty message.
TEST(OpenSslSha256, KnownAnswers) {
  EXPECT_EQ(openssl_sha256(bytes_of("")), from_hex("e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"));
  EXPECT_EQ(openssl_sha256(bytes_of("abc")), from_hex("ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"));
  EXPECT_EQ(openssl_sha256(bytes_of("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq")),
            from_hex("248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1"));
  const std::vector<std::uint8_t> million_a(1'000'000, 'a');
  EXPECT_EQ(openssl_sha256(million_a), from_hex("cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"));
}

TEST(OpenSslSha256, EqualsTheFirmwareHashForEveryLengthAroundTheBlocks) {
  std::mt19937 rng(21);
  std::vector<std::uint8_t> bytes(4096);
  for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
  const std::span<const std::uint8_t> all(bytes);
  for (std::size_t n = 0; n <= 200; ++n) {
    ASSERT_EQ(openssl_sha256(all.subspan(1, n)), trust::sha256(all.subspan(1, n))) << n;
  }
  for (int k = 0; k < 50; ++k) {
    const std::size_t offset = rng() % 16, n = rng() % (bytes.size() - 16);
    ASSERT_EQ(openssl_sha256(all.subspan(offset, n)), trust::sha256(all.subspan(offset, n))) << n;
  }
}

}  // namespace
}  // namespace v2xloc::sim::replay
