#include "firmware/protocol/cloud_signature.hpp"

#include <cstring>

namespace v2xloc::protocol {
namespace {

// Offsets (little-endian integers).
constexpr std::size_t kOffMagic = 0, kOffVersion = 4, kOffHash = 5, kOffSig = 6, kOffReserved0 = 7,
                      kOffSender = 8, kOffSensor = 12, kOffReserved1 = 14, kOffSeq = 16, kOffGenTime = 20,
                      kOffSigner = 28, kOffRS = 36;
static_assert(kOffRS + 64 == signature_wire::kBytes);

std::uint64_t get_le(const std::uint8_t* p, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}
void put_le(std::uint8_t* p, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

}  // namespace

const char* to_string(SignatureParseStatus s) {
  switch (s) {
    case SignatureParseStatus::kOk: return "ok";
    case SignatureParseStatus::kNotSignature: return "not a signature datagram";
    case SignatureParseStatus::kWrongSize: return "wrong size";
    case SignatureParseStatus::kUnsupported: return "unsupported";
  }
  return "?";
}

bool is_signature_datagram(std::span<const std::uint8_t> d) {
  return d.size() >= 4 && get_le(d.data(), 4) == signature_wire::kMagic;
}

SignatureParseStatus parse_signature_datagram(std::span<const std::uint8_t> d, CloudSignature& out) {
  if (!is_signature_datagram(d)) return SignatureParseStatus::kNotSignature;
  if (d.size() != signature_wire::kBytes) return SignatureParseStatus::kWrongSize;
  const std::uint8_t* p = d.data();
  if (p[kOffVersion] != signature_wire::kVersion || p[kOffHash] != signature_wire::kHashSha256 ||
      p[kOffSig] != signature_wire::kSigEcdsaNistP256 || p[kOffReserved0] != 0 || p[kOffReserved1] != 0 ||
      p[kOffReserved1 + 1] != 0) {
    return SignatureParseStatus::kUnsupported;
  }
  CloudSignature s;
  s.sender_id = static_cast<std::uint32_t>(get_le(p + kOffSender, 4));
  s.sensor_id = static_cast<std::uint16_t>(get_le(p + kOffSensor, 2));
  s.frame_seq = static_cast<std::uint32_t>(get_le(p + kOffSeq, 4));
  s.generation_time_ns = get_le(p + kOffGenTime, 8);
  std::memcpy(s.signer.data(), p + kOffSigner, 8);
  std::memcpy(s.signature.data(), p + kOffRS, 64);
  out = s;
  return SignatureParseStatus::kOk;
}

bool encode_signature_datagram(const CloudSignature& s, std::span<std::uint8_t> out) {
  if (out.size() < signature_wire::kBytes) return false;
  std::uint8_t* p = out.data();
  std::memset(p, 0, signature_wire::kBytes);
  put_le(p + kOffMagic, signature_wire::kMagic, 4);
  p[kOffVersion] = signature_wire::kVersion;
  p[kOffHash] = signature_wire::kHashSha256;
  p[kOffSig] = signature_wire::kSigEcdsaNistP256;
  put_le(p + kOffSender, s.sender_id, 4);
  put_le(p + kOffSensor, s.sensor_id, 2);
  put_le(p + kOffSeq, s.frame_seq, 4);
  put_le(p + kOffGenTime, s.generation_time_ns, 8);
  std::memcpy(p + kOffSigner, s.signer.data(), 8);
  std::memcpy(p + kOffRS, s.signature.data(), 64);
  return true;
}

}  // namespace v2xloc::protocol
