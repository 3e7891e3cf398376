// Signature datagrams (firmware/protocol/cloud_signature.hpp) from arbitrary bytes: a datagram
// parses or is refused with a status; one that parses has the signature magic, is exactly
// kBytes long and re-encodes to the same bytes (no field is dropped or invented).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "firmware/protocol/cloud_signature.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::protocol;
  const std::span<const std::uint8_t> bytes(data, size);
  CloudSignature sig;
  const SignatureParseStatus s = parse_signature_datagram(bytes, sig);
  if (to_string(s) == nullptr) std::abort();
  if (s != SignatureParseStatus::kOk) return 0;
  if (!is_signature_datagram(bytes) || size != signature_wire::kBytes) std::abort();
  std::uint8_t again[signature_wire::kBytes] = {};
  if (!encode_signature_datagram(sig, again) || std::memcmp(again, data, size) != 0) std::abort();
  return 0;
}
