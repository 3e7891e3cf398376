// Trust-list files (firmware/trust/trust_list.hpp) from arbitrary bytes: a file parses or is
// refused with a status and a line inside the text; a list that parses holds at most
// kMaxTrustedSigners distinct signers with valid roles, formats to text that parses again to the
// same signers, and every signer is found by its HashedId8.
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
  }
  return 0;
}
