#include "host_sim/replay/openssl_sha256.hpp"

#include <openssl/sha.h>

namespace v2xloc::sim::replay {

trust::Digest openssl_sha256(std::span<const std::uint8_t> bytes) {
  static_assert(SHA256_DIGEST_LENGTH == sizeof(trust::Digest));
  trust::Digest out{};
  SHA256(bytes.data(), bytes.size(), out.data());
  return out;
}

}  // namespace v2xloc::sim::replay
