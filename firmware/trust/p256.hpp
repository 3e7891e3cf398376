// ECDSA over NIST P-256 with SHA-256, the signature suite of IEEE 1609.2 / ETSI TS 103 097
// (ecdsaNistP256 + sha256). Thin, allocation-free wrappers over mbedTLS (memory: crypto_arena).
// Keys on the wire and in the trust list: public keys uncompressed (0x04 || X || Y, 65 bytes),
// private keys 32-byte big-endian scalars, signatures r || s (2 x 32 bytes big-endian).
// A signer is named by its HashedId8: the last 8 bytes of SHA-256 over its public key (1609.2
// names a certificate by the low-order 8 bytes of its hash; we have no certificates, the
// provisioned key plays that part).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace v2xloc::trust {

using Digest = std::array<std::uint8_t, 32>;
using HashedId8 = std::array<std::uint8_t, 8>;
using PublicKey = std::array<std::uint8_t, 65>;
using PrivateKey = std::array<std::uint8_t, 32>;
using Signature = std::array<std::uint8_t, 64>;

// Incremental SHA-256 (context on the caller's stack/static storage, no allocation).
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(std::span<const std::uint8_t> bytes);
  void update_u8(std::uint8_t v) { update(std::span<const std::uint8_t>(&v, 1)); }
  void update_u16(std::uint16_t v);
  void update_u32(std::uint32_t v);
  void update_u64(std::uint64_t v);
  Digest finish();

 private:
  alignas(8) unsigned char ctx_[128];  // mbedtls_sha256_context (checked in p256.cpp)
};

Digest sha256(std::span<const std::uint8_t> bytes);
HashedId8 hashed_id8(const PublicKey& key);

enum class CryptoStatus : std::uint8_t {
  kOk,
  kBadKey,        // not a point on P-256 / scalar out of range
  kBadSignature,  // r or s out of range, or the equation does not hold
  kNoMemory,      // crypto arena exhausted (counted by the arena)
  kError,
};
const char* to_string(CryptoStatus s);

// Checks that `key` is a valid P-256 point (on the curve, not the point at infinity).
CryptoStatus check_public_key(const PublicKey& key);
CryptoStatus verify_digest(const PublicKey& key, const Digest& digest, const Signature& signature);

// Signing side (simulator, test tools; an ECU signing its own shares would use the same calls).
// Deterministic nonces per RFC 6979 (HMAC-DRBG over the key and the digest).
CryptoStatus derive_public_key(const PrivateKey& priv, PublicKey& pub);
CryptoStatus sign_digest(const PrivateKey& priv, const Digest& digest, Signature& signature);
// A valid private key from seed bytes: SHA-256(tag || seed || counter) until it lies in [1, n-1].
PrivateKey private_key_from_seed(std::span<const std::uint8_t> seed);

}  // namespace v2xloc::trust
