// The provisioned trust list: which signers the firmware accepts map shares from, under which
// sender id and with which role. Trust comes only from here, never from a header field: the
// role (infrastructure = surveyed fixed unit, agent = self-localized vehicle) decides how map
// fusion checks a cloud, and a cloud's header sender id must equal its signer's provisioned id.
//
// Text format (one file, e.g. trust_list.txt in a recording folder), UTF-8/ASCII lines:
//   v2xloc-trust-list 1                          (first non-comment line)
//   signer <infrastructure|agent> <sender id> <public key: 130 hex digits, 04 || X || Y> [name]
//   # comment, blank lines ignored
// parse_trust_list() is a pure function over bytes (fuzzable): every key is checked to be a
// P-256 point; duplicates (key or sender id), unknown words, over-long lines and more than
// kMaxTrustedSigners entries are errors with a line number.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/trust/p256.hpp"

namespace v2xloc::trust {

inline constexpr std::size_t kMaxTrustedSigners = 32;
inline constexpr std::size_t kMaxTrustListBytes = 64 * 1024;

enum class SignerRole : std::uint8_t { kInfrastructure, kAgent };
const char* to_string(SignerRole r);

struct TrustedSigner {
  PublicKey key{};
  HashedId8 id{};
  SignerRole role = SignerRole::kAgent;
  std::uint32_t sender_id = 0;
  std::array<char, 32> name{};  // NUL-terminated, informational
};

struct TrustList {
  std::array<TrustedSigner, kMaxTrustedSigners> signers{};
  std::size_t count = 0;

  const TrustedSigner* find(const HashedId8& id) const;
  std::span<const TrustedSigner> view() const { return {signers.data(), count}; }
};

enum class TrustListStatus : std::uint8_t {
  kOk,
  kTooLarge,
  kBadHeader,     // missing or wrong "v2xloc-trust-list 1"
  kSyntax,        // unknown keyword, missing or extra fields, line too long
  kBadRole,
  kBadSenderId,
  kBadKey,        // not 130 hex digits or not a P-256 point
  kDuplicate,     // key (HashedId8) or sender id listed twice
  kTooMany,       // more than kMaxTrustedSigners
};
const char* to_string(TrustListStatus s);

struct TrustListParseResult {
  TrustListStatus status = TrustListStatus::kOk;
  std::size_t line = 0;  // 1-based line of the error
};

TrustListParseResult parse_trust_list(std::span<const std::uint8_t> text, TrustList& out);

// Writes the file text for `list` into `out` (host tools; returns bytes written, 0 if too small).
std::size_t format_trust_list(const TrustList& list, std::span<char> out);

}  // namespace v2xloc::trust
