// Trust-list files (firmware/trust/trust_list.hpp) from arbitrary bytes: a file parses or is
// refused with a status and a line inside the text; a list that parses holds at most
// kMaxTrustedSigners distinct signers with valid roles, surveys only on infrastructure signers
// (finite coordinates and a unit quaternion), backgrounds only on surveyed ones (a flat name that
// cannot leave the list's folder), formats to text that parses again to the same signers,
// bit-identical surveys and the same backgrounds, and every signer is found by its HashedId8.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "firmware/trust/trust_list.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::trust;
  auto list = std::make_unique<TrustList>();
  const TrustListParseResult r = parse_trust_list({data, size}, *list);
  if (to_string(r.status) == nullptr) std::abort();
  if (r.status != TrustListStatus::kOk) {
    if (r.line > size + 1) std::abort();  // the reported line lies inside the text
    return 0;
  }
  if (list->count > kMaxTrustedSigners) std::abort();
  for (const TrustedSigner& s : list->view()) {
    if (s.role != SignerRole::kInfrastructure && s.role != SignerRole::kAgent) std::abort();
    if (list->find(s.id) != &s) std::abort();
    if (s.has_background) {
      if (s.role != SignerRole::kInfrastructure || !s.surveyed) std::abort();
      const std::size_t n = strnlen(s.background_file.data(), s.background_file.size());
      if (n == 0 || n > kMaxBackgroundNameChars || s.background_file[0] == '.') std::abort();
      for (std::size_t i = 0; i < n; ++i) {
        if (s.background_file[i] == '/' || s.background_file[i] == '\\') std::abort();
      }
    }
    if (!s.surveyed) continue;
    if (s.role != SignerRole::kInfrastructure) std::abort();
    double norm2 = 0.0;
    for (const double v : s.survey.position_m) {
      if (!std::isfinite(v) || std::fabs(v) > kMaxSurveyCoordinateM) std::abort();
    }
    for (const double v : s.survey.quaternion_xyzw) norm2 += v * v;
    if (!(std::fabs(std::sqrt(norm2) - 1.0) <= kSurveyQuaternionNormTolerance)) std::abort();
  }
  auto text = std::make_unique<char[]>(kMaxTrustListBytes);
  const std::size_t n = format_trust_list(*list, {text.get(), kMaxTrustListBytes});
  if (n == 0) std::abort();
  auto again = std::make_unique<TrustList>();
  if (parse_trust_list({reinterpret_cast<const std::uint8_t*>(text.get()), n}, *again).status != TrustListStatus::kOk ||
      again->count != list->count)
    std::abort();
  for (std::size_t i = 0; i < list->count; ++i) {
    const TrustedSigner& a = list->signers[i];
    const TrustedSigner& b = again->signers[i];
    if (a.key != b.key || a.id != b.id || a.role != b.role || a.sender_id != b.sender_id) std::abort();
    if (a.surveyed != b.surveyed || std::memcmp(&a.survey, &b.survey, sizeof a.survey) != 0) std::abort();
    if (a.has_background != b.has_background || a.background_file != b.background_file ||
        a.background_sha256 != b.background_sha256)
      std::abort();
  }
  return 0;
}
