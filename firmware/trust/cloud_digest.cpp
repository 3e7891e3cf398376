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

void hash_tag(Sha256& h, const char* tag, std::size_t n) {
  h.update(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(tag), n));
}

}  // namespace

Digest fragment_digest(std::span<const std::uint8_t> payload) { return sha256(payload); }

namespace {

// The header part of cloud_digest(); the fragment digests follow in index order.
void hash_frame_header(Sha256& h, const protocol::ReassembledCloud& cloud) {
  static constexpr char kTag[] = "v2xloc map share fragments v1";
  const protocol::CloudFrameInfo& info = cloud.info;
  hash_tag(h, kTag, sizeof kTag - 1);
  h.update_u8(static_cast<std::uint8_t>(info.type));
  h.update_u32(info.sender_id);
  h.update_u16(info.sensor_id);
  h.update_u32(info.frame_seq);
  h.update_u64(info.timestamp_ns);
  for (const double p : info.pose.position_m) h.update_u64(bits(p));
  for (const double q : info.pose.quaternion_xyzw) h.update_u64(bits(q));
  h.update_u32(bits(info.scale_m));
  h.update_u8(static_cast<std::uint8_t>(info.width));
  h.update_u16(cloud.flags);
  h.update_u32(cloud.point_count + cloud.points_thinned);  // the total sent: a thinned cloud still verifies
  h.update_u16(cloud.fragment_count);
  h.update_u16(cloud.points_per_fragment);
}

}  // namespace

Digest cloud_digest(const protocol::ReassembledCloud& cloud, std::span<const Digest> fragment_digests) {
  Sha256 h;
  hash_frame_header(h, cloud);
  for (const Digest& d : fragment_digests) h.update(d);  // bounded by the fragment count (<= 65535)
  return h.finish();
}

Digest signed_digest(const protocol::CloudSignature& sig, const Digest& cloud) {
  static constexpr char kTag[] = "v2xloc signed map share v1";
  Sha256 h;
  hash_tag(h, kTag, sizeof kTag - 1);
  h.update_u32(sig.sender_id);
  h.update_u16(sig.sensor_id);
  h.update_u32(sig.frame_seq);
  h.update_u64(sig.generation_time_ns);
  h.update(sig.signer);
  h.update(cloud);
  return h.finish();
}

bool ShareDigestBuilder::add(std::span<const std::uint8_t> datagram) {
  protocol::CloudFragmentHeader h;
  std::span<const std::uint8_t> payload;
  if (protocol::parse_cloud_fragment(datagram, h, payload) != protocol::CloudStatus::kOk) return false;
  if (h.fragment_count > scratch_.size()) return false;
  if (!started_) {
    first_ = h;
    started_ = true;
    for (Entry& e : scratch_.first(h.fragment_count)) e = Entry{};
  } else if (h.info.sender_id != first_.info.sender_id || h.info.sensor_id != first_.info.sensor_id ||
             h.info.frame_seq != first_.info.frame_seq || h.fragment_count != first_.fragment_count) {
    return false;
  }
  scratch_[h.fragment_index] = Entry{hash_(payload), true};
  return true;
}

bool ShareDigestBuilder::finish(protocol::ReassembledCloud& frame, Digest& out) const {
  if (!started_) return false;
  for (const Entry& e : scratch_.first(first_.fragment_count)) {
    if (!e.present) return false;
  }
  frame = protocol::ReassembledCloud{};
  frame.info = first_.info;
  frame.point_count = first_.total_points;
  frame.flags = first_.flags;
  frame.fragment_count = first_.fragment_count;
  frame.points_per_fragment = first_.points_per_fragment;
  Sha256 h;
  hash_frame_header(h, frame);
  for (const Entry& e : scratch_.first(first_.fragment_count)) h.update(e.digest);
  out = h.finish();
  return true;
}

CryptoStatus sign_cloud(const PrivateKey& priv, const PublicKey& pub, const protocol::ReassembledCloud& frame,
                        const Digest& cloud, std::uint64_t generation_time_ns, protocol::CloudSignature& out) {
  protocol::CloudSignature sig;
  sig.sender_id = frame.info.sender_id;
  sig.sensor_id = frame.info.sensor_id;
  sig.frame_seq = frame.info.frame_seq;
  sig.generation_time_ns = generation_time_ns;
  sig.signer = hashed_id8(pub);
  const CryptoStatus s = sign_digest(priv, signed_digest(sig, cloud), sig.signature);
  if (s == CryptoStatus::kOk) out = sig;
  return s;
}

}  // namespace v2xloc::trust
