#include "firmware/trust/trust_list.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace v2xloc::trust {
namespace {

constexpr std::size_t kMaxLine = 512;
constexpr std::size_t kMaxTokens = 9;  // survey <id> x y z qx qy qz qw
constexpr std::size_t kMaxNumberChars = 40;

struct Token {
  const char* p = nullptr;
  std::size_t n = 0;
  bool is(const char* s) const { return std::strlen(s) == n && std::memcmp(p, s, n) == 0; }
};

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parse_u32(const Token& t, std::uint32_t& out) {
  if (t.n == 0 || t.n > 10) return false;
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < t.n; ++i) {
    if (t.p[i] < '0' || t.p[i] > '9') return false;
    v = v * 10 + static_cast<std::uint64_t>(t.p[i] - '0');
  }
  if (v > 0xFFFFFFFFull) return false;
  out = static_cast<std::uint32_t>(v);
  return true;
}

// A plain decimal number: [+-]digits[.digits][(e|E)[+-]digits], at least one mantissa digit.
// The grammar keeps out what strtod would also take (nan, inf, hex, locale forms); the value is
// then converted by strtod over a bounded copy and must be finite (1e999 is not).
bool parse_decimal(const Token& t, double& out) {
  if (t.n == 0 || t.n > kMaxNumberChars) return false;
  std::size_t i = 0, digits = 0;
  if (t.p[i] == '+' || t.p[i] == '-') ++i;
  for (; i < t.n && t.p[i] >= '0' && t.p[i] <= '9'; ++i) ++digits;
  if (i < t.n && t.p[i] == '.') {
    for (++i; i < t.n && t.p[i] >= '0' && t.p[i] <= '9'; ++i) ++digits;
  }
  if (digits == 0) return false;
  if (i < t.n && (t.p[i] == 'e' || t.p[i] == 'E')) {
    ++i;
    if (i < t.n && (t.p[i] == '+' || t.p[i] == '-')) ++i;
    std::size_t exp_digits = 0;
    for (; i < t.n && t.p[i] >= '0' && t.p[i] <= '9'; ++i) ++exp_digits;
    if (exp_digits == 0) return false;
  }
  if (i != t.n) return false;
  char buf[kMaxNumberChars + 1];
  std::memcpy(buf, t.p, t.n);
  buf[t.n] = '\0';
  out = std::strtod(buf, nullptr);
  return std::isfinite(out);
}

bool parse_key(const Token& t, PublicKey& key) {
  if (t.n != 2 * key.size()) return false;
  for (std::size_t i = 0; i < key.size(); ++i) {
    const int hi = hex_value(t.p[2 * i]), lo = hex_value(t.p[2 * i + 1]);
    if (hi < 0 || lo < 0) return false;
    key[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  return true;
}

bool is_separator(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// Splits one line into tokens up to a '#' comment; false on a byte outside printable ASCII or
// more than kMaxTokens tokens.
bool tokenize(const char* line, std::size_t len, Token (&tok)[kMaxTokens], std::size_t& nt) {
  nt = 0;
  for (std::size_t i = 0; i < len;) {
    const char c = line[i];
    if (c == '#') break;
    if (is_separator(c)) {
      ++i;
      continue;
    }
    if (static_cast<unsigned char>(c) < 0x21 || static_cast<unsigned char>(c) > 0x7E) return false;
    if (nt == kMaxTokens) return false;
    std::size_t j = i;
    while (j < len && !is_separator(line[j]) && line[j] != '#') ++j;
    tok[nt++] = Token{line + i, j - i};
    i = j;
  }
  return true;
}

// "signer <role> <sender id> <key> [name]" (keyword and field count already checked) into s.
TrustListStatus parse_signer(const Token* tok, std::size_t nt, TrustedSigner& s) {
  if (tok[1].is("infrastructure")) {
    s.role = SignerRole::kInfrastructure;
  } else if (tok[1].is("agent")) {
    s.role = SignerRole::kAgent;
  } else {
    return TrustListStatus::kBadRole;
  }
  if (!parse_u32(tok[2], s.sender_id)) return TrustListStatus::kBadSenderId;
  if (!parse_key(tok[3], s.key) || check_public_key(s.key) != CryptoStatus::kOk) {
    return TrustListStatus::kBadKey;
  }
  s.id = hashed_id8(s.key);
  if (nt == 5) {
    const std::size_t n = tok[4].n < s.name.size() - 1 ? tok[4].n : s.name.size() - 1;
    std::memcpy(s.name.data(), tok[4].p, n);
  }
  return TrustListStatus::kOk;
}

// Appends s unless its key or sender id is listed already or the list is full.
TrustListStatus add_signer(const TrustedSigner& s, TrustList& list) {
  for (std::size_t k = 0; k < list.count; ++k) {
    if (list.signers[k].id == s.id || list.signers[k].sender_id == s.sender_id) {
      return TrustListStatus::kDuplicate;
    }
  }
  if (list.count == kMaxTrustedSigners) return TrustListStatus::kTooMany;
  list.signers[list.count++] = s;
  return TrustListStatus::kOk;
}

// The infrastructure signer listed with this sender id, else null.
TrustedSigner* infrastructure_signer(TrustList& list, std::uint32_t sender_id) {
  for (std::size_t k = 0; k < list.count; ++k) {
    TrustedSigner& s = list.signers[k];
    if (s.sender_id == sender_id) return s.role == SignerRole::kInfrastructure ? &s : nullptr;
  }
  return nullptr;
}

// A flat file name beside the trust list: no separators, no "." / ".." and no hidden files.
bool is_background_name(const Token& t) {
  if (t.n == 0 || t.n > kMaxBackgroundNameChars || t.p[0] == '.') return false;
  for (std::size_t i = 0; i < t.n; ++i) {
    const char c = t.p[i];
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

// "background <sender id> <file> <sha256>" (4 tokens) onto the infrastructure signer listed above.
TrustListStatus parse_background_line(const Token* tok, TrustList& list) {
  std::uint32_t sender_id = 0;
  if (!parse_u32(tok[1], sender_id)) return TrustListStatus::kBadSenderId;
  TrustedSigner* signer = infrastructure_signer(list, sender_id);
  if (signer == nullptr || !signer->surveyed) return TrustListStatus::kBackgroundWithoutSigner;
  if (signer->has_background) return TrustListStatus::kDuplicateBackground;
  if (!is_background_name(tok[2])) return TrustListStatus::kBadBackgroundName;
  Digest digest{};
  if (tok[3].n != 2 * digest.size()) return TrustListStatus::kBadBackgroundDigest;
  for (std::size_t i = 0; i < digest.size(); ++i) {
    const int hi = hex_value(tok[3].p[2 * i]), lo = hex_value(tok[3].p[2 * i + 1]);
    if (hi < 0 || lo < 0) return TrustListStatus::kBadBackgroundDigest;
    digest[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  signer->background_file = {};
  std::memcpy(signer->background_file.data(), tok[2].p, tok[2].n);
  signer->background_sha256 = digest;
  signer->has_background = true;
  return TrustListStatus::kOk;
}

// "survey <sender id> x y z qx qy qz qw" (9 tokens) onto the infrastructure signer listed above.
TrustListStatus parse_survey(const Token* tok, TrustList& list) {
  std::uint32_t sender_id = 0;
  if (!parse_u32(tok[1], sender_id)) return TrustListStatus::kBadSenderId;
  TrustedSigner* signer = infrastructure_signer(list, sender_id);
  if (signer == nullptr) return TrustListStatus::kSurveyWithoutSigner;
  if (signer->surveyed) return TrustListStatus::kDuplicateSurvey;
  SurveyedPose pose;
  for (std::size_t i = 0; i < 3; ++i) {
    if (!parse_decimal(tok[2 + i], pose.position_m[i]) || std::fabs(pose.position_m[i]) > kMaxSurveyCoordinateM) {
      return TrustListStatus::kBadSurveyNumber;
    }
  }
  double norm2 = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    if (!parse_decimal(tok[5 + i], pose.quaternion_xyzw[i]) || std::fabs(pose.quaternion_xyzw[i]) > 2.0) {
      return TrustListStatus::kBadSurveyQuaternion;
    }
    norm2 += pose.quaternion_xyzw[i] * pose.quaternion_xyzw[i];
  }
  if (!(std::fabs(std::sqrt(norm2) - 1.0) <= kSurveyQuaternionNormTolerance)) return TrustListStatus::kBadSurveyQuaternion;
  signer->survey = pose;
  signer->surveyed = true;
  return TrustListStatus::kOk;
}

// One line (without its '\n'): blank or comment, the header (first), a signer or a survey.
TrustListStatus parse_line(const char* line, std::size_t len, bool& header, TrustList& list) {
  if (len > kMaxLine) return TrustListStatus::kSyntax;
  Token tok[kMaxTokens];
  std::size_t nt = 0;
  if (!tokenize(line, len, tok, nt)) return TrustListStatus::kSyntax;
  if (nt == 0) return TrustListStatus::kOk;
  if (!header) {
    if (nt != 2 || !tok[0].is("v2xloc-trust-list") || !tok[1].is("1")) return TrustListStatus::kBadHeader;
    header = true;
    return TrustListStatus::kOk;
  }
  if (tok[0].is("survey")) return nt == 9 ? parse_survey(tok, list) : TrustListStatus::kSyntax;
  if (tok[0].is("background")) return nt == 4 ? parse_background_line(tok, list) : TrustListStatus::kSyntax;
  if (!tok[0].is("signer") || nt < 4 || nt > 5) return TrustListStatus::kSyntax;
  TrustedSigner s;
  const TrustListStatus status = parse_signer(tok, nt, s);
  return status == TrustListStatus::kOk ? add_signer(s, list) : status;
}

}  // namespace

const char* to_string(SignerRole r) { return r == SignerRole::kInfrastructure ? "infrastructure" : "agent"; }

const char* to_string(TrustListStatus s) {
  switch (s) {
    case TrustListStatus::kOk: return "ok";
    case TrustListStatus::kTooLarge: return "file too large";
    case TrustListStatus::kBadHeader: return "missing header 'v2xloc-trust-list 1'";
    case TrustListStatus::kSyntax: return "syntax error";
    case TrustListStatus::kBadRole: return "role must be infrastructure or agent";
    case TrustListStatus::kBadSenderId: return "bad sender id";
    case TrustListStatus::kBadKey: return "bad public key";
    case TrustListStatus::kDuplicate: return "duplicate signer or sender id";
    case TrustListStatus::kTooMany: return "too many signers";
    case TrustListStatus::kSurveyWithoutSigner: return "survey of a sender id with no infrastructure signer listed above";
    case TrustListStatus::kBadSurveyNumber:
      return "survey position must be plain decimal numbers (no nan/inf/hex) within +-100 km";
    case TrustListStatus::kBadSurveyQuaternion: return "survey quaternion must be plain decimal numbers of unit length";
    case TrustListStatus::kDuplicateSurvey: return "second survey for the same signer";
    case TrustListStatus::kBackgroundWithoutSigner:
      return "background of a sender id with no surveyed infrastructure signer (signer and survey lines) above";
    case TrustListStatus::kBadBackgroundName:
      return "background file must be a flat name of 1-63 characters [A-Za-z0-9_.-], not starting with '.'";
    case TrustListStatus::kBadBackgroundDigest: return "background digest must be 64 hex digits (SHA-256)";
    case TrustListStatus::kDuplicateBackground: return "second background for the same signer";
  }
  return "?";
}

const TrustedSigner* TrustList::find(const HashedId8& id) const {
  for (std::size_t i = 0; i < count; ++i) {
    if (signers[i].id == id) return &signers[i];
  }
  return nullptr;
}

std::size_t TrustList::surveyed_count() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < count; ++i) n += signers[i].surveyed ? 1u : 0u;
  return n;
}

std::size_t TrustList::background_count() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < count; ++i) n += signers[i].has_background ? 1u : 0u;
  return n;
}

TrustListParseResult parse_trust_list(std::span<const std::uint8_t> text, TrustList& out) {
  TrustList list;
  TrustListParseResult res;
  if (text.size() > kMaxTrustListBytes) {
    res.status = TrustListStatus::kTooLarge;
    return res;
  }
  const char* const data = reinterpret_cast<const char*>(text.data());
  bool header = false;
  std::size_t pos = 0;
  while (pos < text.size()) {
    ++res.line;
    std::size_t end = pos;
    while (end < text.size() && data[end] != '\n') ++end;
    const TrustListStatus status = parse_line(data + pos, end - pos, header, list);
    if (status != TrustListStatus::kOk) {
      res.status = status;
      return res;
    }
    pos = end + 1;
  }
  if (!header) {
    res.status = TrustListStatus::kBadHeader;
    return res;
  }
  out = list;
  res.status = TrustListStatus::kOk;
  return res;
}

std::size_t format_trust_list(const TrustList& list, std::span<char> out) {
  std::size_t used = 0;
  const auto put = [&](const char* s) {
    const std::size_t n = std::strlen(s);
    if (used + n > out.size()) return false;
    std::memcpy(out.data() + used, s, n);
    used += n;
    return true;
  };
  if (!put("# v2xloc trust list: signer <role> <sender id> <P-256 public key 04||X||Y hex> [name]\n"
           "#   survey <sender id> <x y z [m]> <qx qy qz qw>: an infrastructure unit's surveyed sensor pose\n"
           "#   background <sender id> <file beside this list> <sha256>: its surveyed static background\n"
           "v2xloc-trust-list 1\n")) {
    return 0;
  }
  for (const TrustedSigner& s : list.view()) {
    char line[256];
    int n = std::snprintf(line, sizeof line, "signer %s %u ", to_string(s.role), s.sender_id);
    for (const std::uint8_t b : s.key) n += std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), "%02x", b);
    std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), "%s%s\n", s.name[0] ? " " : "", s.name.data());
    if (!put(line)) return 0;
    if (s.surveyed) {  // %.17g: every double reads back bit-identical
      const SurveyedPose& p = s.survey;
      std::snprintf(line, sizeof line, "survey %u %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", s.sender_id,
                    p.position_m[0], p.position_m[1], p.position_m[2], p.quaternion_xyzw[0], p.quaternion_xyzw[1],
                    p.quaternion_xyzw[2], p.quaternion_xyzw[3]);
      if (!put(line)) return 0;
    }
    if (s.has_background) {
      int at = std::snprintf(line, sizeof line, "background %u %s ", s.sender_id, s.background_file.data());
      for (const std::uint8_t b : s.background_sha256) {
        at += std::snprintf(line + at, sizeof line - static_cast<std::size_t>(at), "%02x", b);
      }
      std::snprintf(line + at, sizeof line - static_cast<std::size_t>(at), "\n");
      if (!put(line)) return 0;
    }
  }
  return used;
}

}  // namespace v2xloc::trust
