// Test support: signs a map share the way a provisioned V2X sender does (signature datagram over
// the reassembled cloud), and the trust list naming that sender.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "firmware/wire/input_decoder.hpp"
#include "firmware/trust/cloud_digest.hpp"

namespace v2xloc::firmware::test {

inline trust::PrivateKey share_key(std::uint32_t sender_id) {
  const std::string seed = "firmware_app test sender " + std::to_string(sender_id);
  return trust::private_key_from_seed(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()));
}

inline void add_signer(trust::TrustList& list, std::uint32_t sender_id, trust::SignerRole role) {
  trust::TrustedSigner& s = list.signers[list.count++];
  trust::derive_public_key(share_key(sender_id), s.key);
  s.id = trust::hashed_id8(s.key);
  s.role = role;
  s.sender_id = sender_id;
}

// The signature datagram for the share made of `fragments`, generated at generation_time_ns.
inline std::vector<std::uint8_t> sign_share(const std::vector<std::vector<std::uint8_t>>& fragments,
                                            std::uint32_t sender_id, std::uint64_t generation_time_ns) {
  auto reassembler = std::make_unique<CloudReassembler>();
  for (const auto& f : fragments) reassembler->push(f, 0);
  trust::PublicKey pub{};
  trust::derive_public_key(share_key(sender_id), pub);
  protocol::CloudSignature sig;
  trust::sign_cloud(share_key(sender_id), pub, reassembler->completed(), generation_time_ns, sig);
  std::vector<std::uint8_t> d(protocol::signature_wire::kBytes);
  protocol::encode_signature_datagram(sig, d);
  return d;
}

}  // namespace v2xloc::firmware::test
