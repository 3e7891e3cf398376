// The provisioned trust list: which signers the firmware accepts map shares from, under which
// sender id and with which role. Trust comes only from here, never from a header field: the
// role (infrastructure = surveyed fixed unit, agent = self-localized vehicle) decides how map
// fusion checks a cloud, and a cloud's header sender id must equal its signer's provisioned id.
//
// Text format (one file, e.g. trust_list.txt in a recording folder), UTF-8/ASCII lines:
//   v2xloc-trust-list 1                          (first non-comment line)
//   signer <infrastructure|agent> <sender id> <public key: 130 hex digits, 04 || X || Y> [name]
//   survey <sender id> <x> <y> <z> <qx> <qy> <qz> <qw>   (optional, after that signer's line)
//   background <sender id> <file> <sha256: 64 hex digits>  (optional, after that signer's line)
//   # comment, blank lines ignored
// A survey line gives an infrastructure unit's surveyed sensor pose (sensor -> map frame: position
// in metres, unit quaternion in x y z w order as in the share header); the firmware refuses that
// unit's shares when the pose they declare differs from it (map_share_verifier.hpp). Infrastructure
// signers without one are trusted on their declared pose as before (older lists parse unchanged).
// A background line names the unit's surveyed background file (background_file.hpp) beside the
// trust list and its SHA-256, so the list vouches for the file: a flat name of 1-63 characters
// [A-Za-z0-9_.-] not starting with '.', one per signer, after the unit's survey line (the
// background checks the points in the unit's sensor frame, the survey where that frame is: one
// without the other would leave a unit half checked).
// parse_trust_list() is a pure function over bytes (fuzzable): every key is checked to be a
// P-256 point; duplicates (key, sender id or a second survey), unknown words, over-long lines,
// more than kMaxTrustedSigners entries, a survey without an infrastructure signer above it, a
// coordinate that is not a plain decimal number (nan, inf, hex) or beyond kMaxSurveyCoordinateM,
// a quaternion that is not unit length, and a background name or digest outside its grammar are
// errors with a line number.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/trust/p256.hpp"

namespace v2xloc::trust {

inline constexpr std::size_t kMaxTrustedSigners = 32;
inline constexpr std::size_t kMaxTrustListBytes = 64 * 1024;
// Survey limits: a local map frame spans kilometres, not 100 km; a surveyed quaternion is written
// with 17 digits, so its norm is 1 to ~1e-16 and 1e-6 only admits rounding of a shorter print.
inline constexpr double kMaxSurveyCoordinateM = 100'000.0;
inline constexpr double kSurveyQuaternionNormTolerance = 1e-6;
inline constexpr std::size_t kMaxBackgroundNameChars = 63;

enum class SignerRole : std::uint8_t { kInfrastructure, kAgent };
const char* to_string(SignerRole r);

// Surveyed sensor pose of an infrastructure unit: sensor frame -> map frame.
struct SurveyedPose {
  std::array<double, 3> position_m{};
  std::array<double, 4> quaternion_xyzw{0.0, 0.0, 0.0, 1.0};
};

struct TrustedSigner {
  PublicKey key{};
  HashedId8 id{};
  SignerRole role = SignerRole::kAgent;
  std::uint32_t sender_id = 0;
  std::array<char, 32> name{};  // NUL-terminated, informational
  bool surveyed = false;        // infrastructure only: `survey` holds its surveyed pose
  SurveyedPose survey{};
  bool has_background = false;  // infrastructure only: a surveyed background file (background_file.hpp)
  std::array<char, kMaxBackgroundNameChars + 1> background_file{};  // NUL-terminated flat name
  Digest background_sha256{};
};

struct TrustList {
  std::array<TrustedSigner, kMaxTrustedSigners> signers{};
  std::size_t count = 0;

  const TrustedSigner* find(const HashedId8& id) const;
  std::size_t surveyed_count() const;
  std::size_t background_count() const;
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
  kSurveyWithoutSigner,   // survey of a sender id with no infrastructure signer above it
  kBadSurveyNumber,       // not a plain decimal number, not finite, or beyond kMaxSurveyCoordinateM
  kBadSurveyQuaternion,   // quaternion norm not 1 within kSurveyQuaternionNormTolerance
  kDuplicateSurvey,       // a second survey line for the same signer
  kBackgroundWithoutSigner,  // background of a sender id with no surveyed infrastructure signer above
  kBadBackgroundName,     // not a flat name of 1-63 characters [A-Za-z0-9_.-], or starting with '.'
  kBadBackgroundDigest,   // not 64 hex digits
  kDuplicateBackground,   // a second background line for the same signer
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
