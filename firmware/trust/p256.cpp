#include "firmware/trust/p256.hpp"

#include <mbedtls/bignum.h>
#include <mbedtls/ecdsa.h>
#include <mbedtls/ecp.h>
#include <mbedtls/sha256.h>

#include <cstring>

#include "firmware/trust/crypto_arena.hpp"
#include "hal/little_endian.hpp"

namespace v2xloc::trust {
namespace {

static_assert(sizeof(mbedtls_sha256_context) <= 128, "Sha256::ctx_ too small");

mbedtls_sha256_context* ctx(unsigned char* raw) { return reinterpret_cast<mbedtls_sha256_context*>(raw); }

CryptoStatus map_error(int rc) {
  if (rc == 0) return CryptoStatus::kOk;
  if (rc == MBEDTLS_ERR_MPI_ALLOC_FAILED || rc == MBEDTLS_ERR_ECP_ALLOC_FAILED) return CryptoStatus::kNoMemory;
  if (rc == MBEDTLS_ERR_ECP_VERIFY_FAILED) return CryptoStatus::kBadSignature;
  if (rc == MBEDTLS_ERR_ECP_INVALID_KEY || rc == MBEDTLS_ERR_ECP_BAD_INPUT_DATA) return CryptoStatus::kBadKey;
  return CryptoStatus::kError;
}

// The P-256 group, loaded once. Its base-point comb table (~4 KiB of arena, reused by every later
// verification) is built here by one multiplication of G, so the first verification in a period
// does not pay for it (~2.2 M instructions of its 14 M).
mbedtls_ecp_group& group() {
  static mbedtls_ecp_group g;
  static bool loaded = false;
  if (!loaded) {
    mbedtls_ecp_group_init(&g);
    if (mbedtls_ecp_group_load(&g, MBEDTLS_ECP_DP_SECP256R1) == 0) {
      loaded = true;
      mbedtls_mpi two;
      mbedtls_ecp_point twice_g;
      mbedtls_mpi_init(&two);
      mbedtls_ecp_point_init(&twice_g);
      if (mbedtls_mpi_lset(&two, 2) == 0) (void)mbedtls_ecp_mul(&g, &twice_g, &two, &g.G, nullptr, nullptr);
      mbedtls_ecp_point_free(&twice_g);
      mbedtls_mpi_free(&two);
    }
  }
  return g;
}

// RAII over mbedTLS objects (their memory comes from the arena).
struct Mpi {
  mbedtls_mpi v;
  Mpi() { mbedtls_mpi_init(&v); }
  ~Mpi() { mbedtls_mpi_free(&v); }
};
struct Point {
  mbedtls_ecp_point v;
  Point() { mbedtls_ecp_point_init(&v); }
  ~Point() { mbedtls_ecp_point_free(&v); }
};

}  // namespace

Sha256::Sha256() {
  (void)crypto_arena_stats();  // keeps the arena object linked ahead of mbedcrypto (CMakeLists.txt)
  mbedtls_sha256_init(ctx(ctx_));
  mbedtls_sha256_starts_ret(ctx(ctx_), 0);
}
Sha256::~Sha256() { mbedtls_sha256_free(ctx(ctx_)); }
void Sha256::update(std::span<const std::uint8_t> bytes) {
  if (!bytes.empty()) mbedtls_sha256_update_ret(ctx(ctx_), bytes.data(), bytes.size());
}
void Sha256::update_u16(std::uint16_t v) {
  std::uint8_t b[2];
  hal::le::put_u16(b, v);
  update(b);
}
void Sha256::update_u32(std::uint32_t v) {
  std::uint8_t b[4];
  hal::le::put_u32(b, v);
  update(b);
}
void Sha256::update_u64(std::uint64_t v) {
  std::uint8_t b[8];
  hal::le::put_u64(b, v);
  update(b);
}
Digest Sha256::finish() {
  Digest d{};
  mbedtls_sha256_finish_ret(ctx(ctx_), d.data());
  return d;
}

Digest sha256(std::span<const std::uint8_t> bytes) {
  Sha256 h;
  h.update(bytes);
  return h.finish();
}

HashedId8 hashed_id8(const PublicKey& key) {
  const Digest d = sha256(key);
  HashedId8 id{};
  std::memcpy(id.data(), d.data() + 24, 8);  // low-order 8 bytes of the hash
  return id;
}

const char* to_string(CryptoStatus s) {
  switch (s) {
    case CryptoStatus::kOk: return "ok";
    case CryptoStatus::kBadKey: return "bad key";
    case CryptoStatus::kBadSignature: return "bad signature";
    case CryptoStatus::kNoMemory: return "crypto arena exhausted";
    case CryptoStatus::kError: return "crypto error";
  }
  return "?";
}

CryptoStatus check_public_key(const PublicKey& key) {
  mbedtls_ecp_group& g = group();
  Point q;
  int rc = mbedtls_ecp_point_read_binary(&g, &q.v, key.data(), key.size());
  if (rc != 0) return rc == MBEDTLS_ERR_MPI_ALLOC_FAILED ? CryptoStatus::kNoMemory : CryptoStatus::kBadKey;
  rc = mbedtls_ecp_check_pubkey(&g, &q.v);
  return rc == 0 ? CryptoStatus::kOk : (rc == MBEDTLS_ERR_MPI_ALLOC_FAILED ? CryptoStatus::kNoMemory : CryptoStatus::kBadKey);
}

CryptoStatus verify_digest(const PublicKey& key, const Digest& digest, const Signature& signature) {
  mbedtls_ecp_group& g = group();
  Point q;
  Mpi r, s;
  int rc = mbedtls_ecp_point_read_binary(&g, &q.v, key.data(), key.size());
  if (rc != 0) return rc == MBEDTLS_ERR_MPI_ALLOC_FAILED ? CryptoStatus::kNoMemory : CryptoStatus::kBadKey;
  if ((rc = mbedtls_mpi_read_binary(&r.v, signature.data(), 32)) != 0) return map_error(rc);
  if ((rc = mbedtls_mpi_read_binary(&s.v, signature.data() + 32, 32)) != 0) return map_error(rc);
  // mbedtls_ecdsa_verify checks 1 <= r, s < n and that Q is a valid point.
  rc = mbedtls_ecdsa_verify(&g, digest.data(), digest.size(), &q.v, &r.v, &s.v);
  if (rc == MBEDTLS_ERR_ECP_INVALID_KEY) return CryptoStatus::kBadKey;
  return rc == 0 ? CryptoStatus::kOk : (map_error(rc) == CryptoStatus::kNoMemory ? CryptoStatus::kNoMemory
                                                                                  : CryptoStatus::kBadSignature);
}

CryptoStatus derive_public_key(const PrivateKey& priv, PublicKey& pub) {
  mbedtls_ecp_group& g = group();
  Mpi d;
  Point q;
  int rc = mbedtls_mpi_read_binary(&d.v, priv.data(), priv.size());
  if (rc != 0) return map_error(rc);
  if (mbedtls_ecp_check_privkey(&g, &d.v) != 0) return CryptoStatus::kBadKey;
  // No RNG: mbedTLS 2.28 then blinds with an internal deterministic DRBG.
  if ((rc = mbedtls_ecp_mul(&g, &q.v, &d.v, &g.G, nullptr, nullptr)) != 0) return map_error(rc);
  std::size_t len = 0;
  rc = mbedtls_ecp_point_write_binary(&g, &q.v, MBEDTLS_ECP_PF_UNCOMPRESSED, &len, pub.data(), pub.size());
  return rc == 0 && len == pub.size() ? CryptoStatus::kOk : map_error(rc == 0 ? -1 : rc);
}

CryptoStatus sign_digest(const PrivateKey& priv, const Digest& digest, Signature& signature) {
  mbedtls_ecp_group& g = group();
  Mpi d, r, s;
  int rc = mbedtls_mpi_read_binary(&d.v, priv.data(), priv.size());
  if (rc != 0) return map_error(rc);
  if (mbedtls_ecp_check_privkey(&g, &d.v) != 0) return CryptoStatus::kBadKey;
  rc = mbedtls_ecdsa_sign_det_ext(&g, &r.v, &s.v, &d.v, digest.data(), digest.size(), MBEDTLS_MD_SHA256, nullptr,
                                  nullptr);
  if (rc != 0) return map_error(rc);
  if ((rc = mbedtls_mpi_write_binary(&r.v, signature.data(), 32)) != 0) return map_error(rc);
  if ((rc = mbedtls_mpi_write_binary(&s.v, signature.data() + 32, 32)) != 0) return map_error(rc);
  return CryptoStatus::kOk;
}

PrivateKey private_key_from_seed(std::span<const std::uint8_t> seed) {
  static constexpr char kTag[] = "v2xloc p256 key from seed v1";
  mbedtls_ecp_group& g = group();
  for (std::uint32_t counter = 0;; ++counter) {
    Sha256 h;
    h.update(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(kTag), sizeof kTag - 1));
    h.update(seed);
    h.update_u32(counter);
    PrivateKey k{};
    const Digest dg = h.finish();
    std::memcpy(k.data(), dg.data(), k.size());
    Mpi d;
    if (mbedtls_mpi_read_binary(&d.v, k.data(), k.size()) == 0 && mbedtls_ecp_check_privkey(&g, &d.v) == 0) return k;
  }
}

}  // namespace v2xloc::trust
