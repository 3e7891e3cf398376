// Shared set-up of the trust-list tests: parse / format through strings, and a two-signer list
// (infrastructure unit 1, agent 32) with keys derived from a per-test seed.
#pragma once

#include <string>

#include "firmware/trust/p256.hpp"
#include "firmware/trust/trust_list.hpp"

namespace v2xloc::trust::test {

inline TrustListParseResult parse(const std::string& s, TrustList& out) {
  return parse_trust_list(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()), out);
}

inline std::string text_of(const TrustList& l) {
  std::string buf(8192, '\0');
  buf.resize(format_trust_list(l, {buf.data(), buf.size()}));
  return buf;
}

// Signer 0: infrastructure unit 1, signer 1: agent 32; keys from "<seed_prefix><index>".
inline TrustList infra_and_agent(const std::string& seed_prefix) {
  TrustList l;
  for (int i = 0; i < 2; ++i) {
    const std::string seed = seed_prefix + std::to_string(i);
    TrustedSigner& s = l.signers[l.count++];
    derive_public_key(private_key_from_seed(std::span<const std::uint8_t>(
                          reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size())),
                      s.key);
    s.id = hashed_id8(s.key);
    s.role = i == 0 ? SignerRole::kInfrastructure : SignerRole::kAgent;
    s.sender_id = i == 0 ? 1u : 32u;
  }
  return l;
}

}  // namespace v2xloc::trust::test
