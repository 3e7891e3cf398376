// What a map-share signature covers. cloud_digest(): SHA-256 over the decoded cloud exactly as
// the receiver reassembled it (message type, sender, sensor, seq, time stamp, sensor pose, scale,
// width, point count, then every point's x, y, z as IEEE-754 float bits, intensities and time
// ticks when present), so it is independent of fragmentation and of the order fragments arrived
// in; a sender computes it by reassembling its own fragments. signed_digest(): SHA-256 over a
// domain tag, the signature datagram's fields (sender, sensor, seq, generation time, signer) and
// the cloud digest; this is what ECDSA signs, so no field of the signature datagram can be
// changed without breaking it.
#pragma once

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/trust/p256.hpp"

namespace v2xloc::trust {

Digest cloud_digest(const protocol::ReassembledCloud& cloud);
Digest signed_digest(const protocol::CloudSignature& sig, const Digest& cloud);

}  // namespace v2xloc::trust

namespace v2xloc::trust {

// Signer side: the signature datagram for `cloud` (as the receiver will reassemble it), signed
// with `priv` (whose public key is `pub`) at generation time generation_time_ns.
CryptoStatus sign_cloud(const PrivateKey& priv, const PublicKey& pub, const protocol::ReassembledCloud& cloud,
                        std::uint64_t generation_time_ns, protocol::CloudSignature& out);

}  // namespace v2xloc::trust
