// ECDSA P-256 / SHA-256 through the firmware's mbedTLS copy: RFC 6979 known answers (so the
// simulator's signatures are deterministic and standard), rejection of tampered inputs, and no
// heap: every allocation mbedTLS makes is served by the static crypto arena.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "firmware/app/alloc_counter.hpp"
#include "firmware/trust/crypto_arena.hpp"
#include "firmware/trust/p256.hpp"

namespace v2xloc::trust {
namespace {

template <std::size_t N>
std::array<std::uint8_t, N> from_hex(const std::string& hex) {
  std::array<std::uint8_t, N> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = static_cast<std::uint8_t>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
  return out;
}

std::span<const std::uint8_t> bytes(const char* s) {
  return {reinterpret_cast<const std::uint8_t*>(s), std::strlen(s)};
}

// RFC 6979, A.2.5 (ECDSA, 256 bits, prime field), message "sample" with SHA-256.
const PrivateKey kRfcKey = from_hex<32>("C9AFA9D845BA75166B5C215767B1D6934E50C3DB36E89B127B8A622B120F6721");
const PublicKey kRfcPub = from_hex<65>(
    "0460FED4BA255A9D31C961EB74C6356D68C049B8923B61FA6CE669622E60F29FB6"
    "7903FE1008B8BC99A41AE9E95628BC64F2F1B20C2D7E9F5177A3C294D4462299");
const Signature kRfcSig = from_hex<64>(
    "EFD48B2AACB6A8FD1140DD9CD45E81D69D2C877B56AAF991C34D0EA84EAF3716"
    "F7CB1C942D657C41D436C7A1B6E29F65F3E900DBB9AFF4064DC4AB2F843ACDA8");

TEST(P256, Sha256KnownAnswer) {
  const Digest d = sha256(bytes("abc"));
  EXPECT_EQ(d, from_hex<32>("BA7816BF8F01CFEA414140DE5DAE2223B00361A396177A9CB410FF61F20015AD"));
}

TEST(P256, Rfc6979DeterministicSignatureKnownAnswer) {
  PublicKey pub{};
  ASSERT_EQ(derive_public_key(kRfcKey, pub), CryptoStatus::kOk);
  EXPECT_EQ(pub, kRfcPub);
  Signature sig{};
  ASSERT_EQ(sign_digest(kRfcKey, sha256(bytes("sample")), sig), CryptoStatus::kOk);
  EXPECT_EQ(sig, kRfcSig);
  EXPECT_EQ(verify_digest(kRfcPub, sha256(bytes("sample")), kRfcSig), CryptoStatus::kOk);
}

TEST(P256, TamperedDigestSignatureOrKeyFail) {
  const Digest d = sha256(bytes("sample"));
  Digest d2 = d;
  d2[31] ^= 1;
  EXPECT_EQ(verify_digest(kRfcPub, d2, kRfcSig), CryptoStatus::kBadSignature);
  for (const std::size_t byte : {0u, 31u, 32u, 63u}) {
    Signature s = kRfcSig;
    s[byte] ^= 0x80;
    EXPECT_EQ(verify_digest(kRfcPub, d, s), CryptoStatus::kBadSignature) << byte;
  }
  Signature zero{};
  EXPECT_EQ(verify_digest(kRfcPub, d, zero), CryptoStatus::kBadSignature);  // r = s = 0 out of range
  PublicKey off_curve = kRfcPub;
  off_curve[64] ^= 1;
  EXPECT_EQ(check_public_key(off_curve), CryptoStatus::kBadKey);
  EXPECT_NE(verify_digest(off_curve, d, kRfcSig), CryptoStatus::kOk);
  PublicKey compressed_tag = kRfcPub;
  compressed_tag[0] = 0x02;
  EXPECT_EQ(check_public_key(compressed_tag), CryptoStatus::kBadKey);
}

TEST(P256, HashedId8IsLowOrderEightBytesOfKeyHash) {
  const Digest d = sha256(kRfcPub);
  const HashedId8 id = hashed_id8(kRfcPub);
  EXPECT_EQ(0, std::memcmp(id.data(), d.data() + 24, 8));
}

TEST(P256, SeededKeysAreDeterministicAndDistinct) {
  const PrivateKey a = private_key_from_seed(bytes("infra_0"));
  EXPECT_EQ(a, private_key_from_seed(bytes("infra_0")));
  EXPECT_NE(a, private_key_from_seed(bytes("infra_1")));
}

TEST(P256, VerificationUsesTheStaticArenaNotTheHeap) {
  const Digest d = sha256(bytes("sample"));
  ASSERT_EQ(verify_digest(kRfcPub, d, kRfcSig), CryptoStatus::kOk);  // warm-up: group table cached
  const std::size_t carved = crypto_arena_stats().carved_bytes;
  const std::uint64_t arena_allocs = crypto_arena_stats().allocations;
  {
    // Counts operator new and (outside sanitizer builds) malloc / calloc: mbedTLS's calloc calls
    // are renamed to the arena, so none reach the heap.
    firmware::alloc_counter::Scope scope;
    for (int i = 0; i < 5; ++i) ASSERT_EQ(verify_digest(kRfcPub, d, kRfcSig), CryptoStatus::kOk);
    EXPECT_EQ(scope.allocations(), 0u) << (firmware::alloc_counter::malloc_is_counted() ? "" : "(operator new only)");
  }
  EXPECT_GT(crypto_arena_stats().allocations, arena_allocs + 1000) << "mbedTLS allocated through the arena";
  EXPECT_EQ(crypto_arena_stats().carved_bytes, carved) << "steady state: free lists recycle, arena does not grow";
  EXPECT_EQ(crypto_arena_stats().failed, 0u);
  EXPECT_LT(crypto_arena_stats().carved_bytes, kCryptoArenaBytes / 2);
  std::printf("crypto arena: carved %zu B, peak live %zu B\n", crypto_arena_stats().carved_bytes,
              crypto_arena_stats().peak_live_bytes);
}

}  // namespace
}  // namespace v2xloc::trust
