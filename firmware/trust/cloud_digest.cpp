#include "firmware/trust/cloud_digest.hpp"

#include <cstring>

namespace v2xloc::trust {
namespace {

std::uint64_t bits(double v) {
  std::uint64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}
std::uint32_t bits(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

}  // namespace

Digest cloud_digest(const protocol::ReassembledCloud& cloud) {
  const protocol::CloudFrameInfo& info = cloud.info;
  Sha256 h;
  h.update_u8(static_cast<std::uint8_t>(info.type));
  h.update_u32(info.sender_id);
  h.update_u16(info.sensor_id);
  h.update_u32(info.frame_seq);
  h.update_u64(info.timestamp_ns);
  for (const double p : info.pose.position_m) h.update_u64(bits(p));
  for (const double q : info.pose.quaternion_xyzw) h.update_u64(bits(q));
  h.update_u32(bits(info.scale_m));
  h.update_u8(static_cast<std::uint8_t>(info.width));
  h.update_u32(cloud.point_count);
  // Points in blocks (little-endian float bits), so hashing costs one mbedTLS call per block.
  std::uint8_t block[3 * 4 * 64];
  std::size_t fill = 0;
  for (const float v : cloud.xyz) {
    const std::uint32_t b = bits(v);
    for (int i = 0; i < 4; ++i) block[fill++] = static_cast<std::uint8_t>(b >> (8 * i));
    if (fill == sizeof block) {
      h.update(block);
      fill = 0;
    }
  }
  h.update(std::span<const std::uint8_t>(block, fill));
  h.update_u8(cloud.intensity.empty() ? 0 : 1);
  h.update(cloud.intensity);
  h.update_u8(cloud.time_offset_ticks.empty() ? 0 : 1);
  for (const std::uint16_t t : cloud.time_offset_ticks) h.update_u16(t);
  return h.finish();
}

Digest signed_digest(const protocol::CloudSignature& sig, const Digest& cloud) {
  static constexpr char kTag[] = "v2xloc signed map share v1";
  Sha256 h;
  h.update(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(kTag), sizeof kTag - 1));
  h.update_u32(sig.sender_id);
  h.update_u16(sig.sensor_id);
  h.update_u32(sig.frame_seq);
  h.update_u64(sig.generation_time_ns);
  h.update(sig.signer);
  h.update(cloud);
  return h.finish();
}

}  // namespace v2xloc::trust

namespace v2xloc::trust {

CryptoStatus sign_cloud(const PrivateKey& priv, const PublicKey& pub, const protocol::ReassembledCloud& cloud,
                        std::uint64_t generation_time_ns, protocol::CloudSignature& out) {
  protocol::CloudSignature sig;
  sig.sender_id = cloud.info.sender_id;
  sig.sensor_id = cloud.info.sensor_id;
  sig.frame_seq = cloud.info.frame_seq;
  sig.generation_time_ns = generation_time_ns;
  sig.signer = hashed_id8(pub);
  const CryptoStatus s = sign_digest(priv, signed_digest(sig, cloud_digest(cloud)), sig.signature);
  if (s == CryptoStatus::kOk) out = sig;
  return s;
}

}  // namespace v2xloc::trust
