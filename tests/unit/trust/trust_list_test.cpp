// Trust-list text: round trip, and every malformed input rejected with its status and line.
#include <gtest/gtest.h>

#include <string>

#include "firmware/trust/trust_list.hpp"

namespace v2xloc::trust {
namespace {

TrustListParseResult parse(const std::string& s, TrustList& out) {
  return parse_trust_list(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()), out);
}

TrustList two_signers() {
  TrustList l;
  for (int i = 0; i < 2; ++i) {
    const std::string seed = "unit " + std::to_string(i);
    TrustedSigner& s = l.signers[l.count++];
    const PrivateKey k = private_key_from_seed(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()));
    EXPECT_EQ(derive_public_key(k, s.key), CryptoStatus::kOk);
    s.id = hashed_id8(s.key);
    s.role = i == 0 ? SignerRole::kInfrastructure : SignerRole::kAgent;
    s.sender_id = i == 0 ? 1u : 32u;
    s.name[0] = 'u';
  }
  return l;
}

std::string text_of(const TrustList& l) {
  char buf[4096];
  const std::size_t n = format_trust_list(l, buf);
  return std::string(buf, n);
}

TEST(TrustList, RoundTrip) {
  const TrustList l = two_signers();
  const std::string text = text_of(l);
  TrustList back;
  ASSERT_EQ(parse(text, back).status, TrustListStatus::kOk) << text;
  ASSERT_EQ(back.count, 2u);
  EXPECT_EQ(back.signers[0].key, l.signers[0].key);
  EXPECT_EQ(back.signers[0].role, SignerRole::kInfrastructure);
  EXPECT_EQ(back.signers[1].role, SignerRole::kAgent);
  EXPECT_EQ(back.signers[1].sender_id, 32u);
  EXPECT_NE(back.find(l.signers[1].id), nullptr);
  HashedId8 unknown{};
  EXPECT_EQ(back.find(unknown), nullptr);
}

TEST(TrustList, MalformedInputsAreRejectedWithTheirLine) {
  const TrustList l = two_signers();
  const std::string good = text_of(l);
  const std::string key0 = good.substr(good.find("signer infrastructure 1 ") + 24, 130);
  struct Case {
    std::string text;
    TrustListStatus status;
    std::size_t line;
  };
  const Case cases[] = {
      {"", TrustListStatus::kBadHeader, 0},
      {"v2xloc-trust-list 2\n", TrustListStatus::kBadHeader, 1},
      {"v2xloc-trust-list 1\nsigner infrastructure 1\n", TrustListStatus::kSyntax, 2},
      {"v2xloc-trust-list 1\nsigner boss 1 " + key0 + "\n", TrustListStatus::kBadRole, 2},
      {"v2xloc-trust-list 1\nsigner agent -1 " + key0 + "\n", TrustListStatus::kBadSenderId, 2},
      {"v2xloc-trust-list 1\nsigner agent 99999999999 " + key0 + "\n", TrustListStatus::kBadSenderId, 2},
      {"v2xloc-trust-list 1\nsigner agent 3 " + key0.substr(0, 128) + "zz\n", TrustListStatus::kBadKey, 2},
      {"v2xloc-trust-list 1\nsigner agent 3 " + key0.substr(0, 128) + "00\n", TrustListStatus::kBadKey, 2},
      {"v2xloc-trust-list 1\nsigner agent 3 " + key0 + "\nsigner agent 4 " + key0 + "\n", TrustListStatus::kDuplicate, 3},
      {"v2xloc-trust-list 1\nsigner agent 3 " + key0 + " a b\n", TrustListStatus::kSyntax, 2},
      {"v2xloc-trust-list 1\n" + std::string(600, 'x') + "\n", TrustListStatus::kSyntax, 2},
      {std::string("v2xloc-trust-list 1\nsig\0ner\n", 29), TrustListStatus::kSyntax, 2},
  };
  for (const Case& c : cases) {
    TrustList out;
    const TrustListParseResult r = parse(c.text, out);
    EXPECT_EQ(r.status, c.status) << c.text.substr(0, 80);
    EXPECT_EQ(r.line, c.line) << c.text.substr(0, 80);
    EXPECT_EQ(out.count, 0u);
  }
}

TEST(TrustList, CapacityIsEnforced) {
  std::string text = "v2xloc-trust-list 1\n";
  for (std::size_t i = 0; i <= kMaxTrustedSigners; ++i) {
    const std::string seed = "cap " + std::to_string(i);
    TrustList one;
    TrustedSigner& s = one.signers[one.count++];
    derive_public_key(private_key_from_seed(std::span<const std::uint8_t>(
                          reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size())),
                      s.key);
    s.sender_id = static_cast<std::uint32_t>(100 + i);
    const std::string t = text_of(one);
    text += t.substr(t.find("\nsigner") + 1);
  }
  TrustList out;
  EXPECT_EQ(parse(text, out).status, TrustListStatus::kTooMany);
}

}  // namespace
}  // namespace v2xloc::trust
