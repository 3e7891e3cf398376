// V2X map-share signature datagram (the "trailer" of a signed cloud; WIRE_FORMATS.md, "Signed map
// shares"). One datagram per cloud, sent before the cloud's fragments, names the cloud by
// (sender id, sensor id, frame seq) and carries the signer's HashedId8, the generation time and an
// ECDSA P-256 signature r || s over SHA-256 of the signed fields and the whole cloud's digest
// (firmware/trust/cloud_digest.hpp). Pure byte codec, no crypto, no allocation: a fuzz target can
// call parse_signature_datagram() on arbitrary bytes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace v2xloc::protocol {

namespace signature_wire {
inline constexpr std::uint32_t kMagic = 0x53583256u;  // bytes 'V','2','X','S' on the wire
inline constexpr std::uint8_t kVersion = 1;
inline constexpr std::uint8_t kHashSha256 = 1;
inline constexpr std::uint8_t kSigEcdsaNistP256 = 1;
inline constexpr std::size_t kBytes = 100;
}  // namespace signature_wire

struct CloudSignature {
  std::uint32_t sender_id = 0;
  std::uint16_t sensor_id = 0;
  std::uint32_t frame_seq = 0;
  std::uint64_t generation_time_ns = 0;  // signer's disciplined time when it signed
  std::array<std::uint8_t, 8> signer{};  // HashedId8 of the signer's public key
  std::array<std::uint8_t, 64> signature{};  // r || s, big-endian
};

enum class SignatureParseStatus : std::uint8_t {
  kOk,
  kNotSignature,  // first 4 bytes are not the signature magic (maybe a cloud fragment)
  kWrongSize,
  kUnsupported,   // version, hash or signature algorithm unknown, reserved bytes not 0
};
const char* to_string(SignatureParseStatus s);

// True when the datagram starts with the signature magic (cheap dispatch before parsing).
bool is_signature_datagram(std::span<const std::uint8_t> datagram);
SignatureParseStatus parse_signature_datagram(std::span<const std::uint8_t> datagram, CloudSignature& out);
// Writes kBytes; false when `out` is smaller.
bool encode_signature_datagram(const CloudSignature& sig, std::span<std::uint8_t> out);

}  // namespace v2xloc::protocol
