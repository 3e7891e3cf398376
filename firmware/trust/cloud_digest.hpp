// What a map-share signature covers: the bytes that arrived, not a re-encoding of decoded points.
//
// fragment_digest(): SHA-256 over one fragment's payload bytes exactly as on the wire (quantized
// coordinates, intensity, time ticks; WIRE_FORMATS.md "UDP point clouds"). The receiver hashes each
// fragment once, when the reassembler accepts it, so the cost is spread over the arrival of the
// fragments and no point is re-encoded.
// cloud_digest(): SHA-256 over a domain tag, the frame-constant header fields (message type,
// sender, sensor, seq, time stamp, sensor pose, scale, width, flags, total points, fragment count,
// points per fragment) and then the fragment digests IN FRAGMENT INDEX ORDER, so it does not depend
// on the order the fragments arrived in. A sender computes it from its own datagrams
// (ShareDigestBuilder).
// signed_digest(): SHA-256 over a domain tag, the signature datagram's fields (sender, sensor, seq,
// generation time, signer) and the cloud digest; this is what ECDSA signs, so no field of the
// signature datagram can be changed without breaking it.
#pragma once

#include <span>

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/trust/p256.hpp"

namespace v2xloc::trust {

Digest fragment_digest(std::span<const std::uint8_t> payload);
// fragment_digests.size() must equal cloud.fragment_count (the caller's table for the frame).
Digest cloud_digest(const protocol::ReassembledCloud& cloud, std::span<const Digest> fragment_digests);
Digest signed_digest(const protocol::CloudSignature& sig, const Digest& cloud);

// Sender side: the cloud digest of one frame from its datagrams, in any order. Scratch storage is
// the caller's (one entry per fragment). add() is false for a datagram that does not parse, does
// not belong to the first datagram's frame, or does not fit the scratch; finish() is false until
// every fragment was added.
class ShareDigestBuilder {
 public:
  struct Entry {
    Digest digest{};
    bool present = false;
  };
  // Hashes a fragment's payload: fragment_digest(), or any other SHA-256 of it (a host sender may
  // pass a hardware-accelerated one).
  using PayloadHash = Digest (*)(std::span<const std::uint8_t>);
  explicit ShareDigestBuilder(std::span<Entry> scratch, PayloadHash hash = fragment_digest)
      : scratch_(scratch), hash_(hash) {}
  bool add(std::span<const std::uint8_t> datagram);
  bool finish(protocol::ReassembledCloud& frame, Digest& out) const;

 private:
  std::span<Entry> scratch_;
  PayloadHash hash_;
  protocol::CloudFragmentHeader first_{};
  bool started_ = false;
};

// Signer side: the signature datagram for the frame `frame` (header fields; see finish()) whose
// cloud digest is `cloud`, signed with `priv` (public key `pub`) at generation_time_ns.
CryptoStatus sign_cloud(const PrivateKey& priv, const PublicKey& pub, const protocol::ReassembledCloud& frame,
                        const Digest& cloud, std::uint64_t generation_time_ns, protocol::CloudSignature& out);

}  // namespace v2xloc::trust
