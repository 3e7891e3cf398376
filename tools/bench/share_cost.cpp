// Cost of trusting V2X map shares, for a callgrind run (not a Google Benchmark: it counts
// instructions of exactly one scenario). Six provisioned sources each send a signed 16 000-point
// share in the same 10 Hz period, then the ego scan closes the period. Phases are separate
// non-inlined functions so a profile can be restricted to one of them:
//   valgrind --tool=callgrind --toggle-collect='*receive_shares*' build/host/bin/v2xloc-share-cost
//   valgrind --tool=callgrind --toggle-collect='*close_period*'   build/host/bin/v2xloc-share-cost
// (callgrind_annotate --inclusive=yes splits the receive phase into reassembly, fragment hashing
// and queueing). Prints what the decoder did so a run is checked, not only timed.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "firmware/trust/cloud_digest.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/wire_conventions.hpp"

namespace {

using namespace v2xloc;
constexpr std::int64_t kEpoch = 1'700'000'000'000'000'000;
constexpr std::uint32_t kSources = 6;
constexpr std::size_t kPoints = 16000;
constexpr std::int64_t kNow = 500'000'000;

using Datagrams = std::vector<std::vector<std::uint8_t>>;

trust::PrivateKey key_of(std::uint32_t sender) {
  const std::string seed = "share cost sender " + std::to_string(sender);
  return trust::private_key_from_seed(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()));
}

Datagrams fragment(protocol::CloudMessageType type, std::uint32_t sender, std::size_t n, std::uint32_t seq = 0,
                   std::int64_t stamp_ns = kNow) {
  std::vector<float> xyz;
  for (std::size_t i = 0; i < n; ++i) {
    xyz.push_back(0.003f * static_cast<float>(i % 9000) - 10.0f);
    xyz.push_back(0.05f * static_cast<float>(i % 311) - 7.0f);
    xyz.push_back(0.01f * static_cast<float>(i % 97));
  }
  protocol::CloudFrameInfo info;
  info.type = type;
  info.sender_id = sender;
  info.frame_seq = seq;
  info.timestamp_ns = static_cast<std::uint64_t>(kEpoch + stamp_ns);
  info.scale_m = firmware::kCloudScaleM;
  protocol::PointCloudFragmenter f;
  f.begin(info, protocol::CloudPointsView{xyz, {}, {}});
  Datagrams out;
  std::vector<std::uint8_t> buf(protocol::pointcloud_wire::kMaxDatagramBytes);
  std::size_t written = 0;
  while (f.next(buf, written) == protocol::CloudStatus::kOk) out.emplace_back(buf.begin(), buf.begin() + static_cast<long>(written));
  return out;
}

std::vector<std::uint8_t> sign(const Datagrams& frags, std::uint32_t sender) {
  std::vector<trust::ShareDigestBuilder::Entry> scratch(frags.size());
  trust::ShareDigestBuilder builder(scratch);
  for (const auto& d : frags) builder.add(d);
  protocol::ReassembledCloud frame;
  trust::Digest digest{};
  builder.finish(frame, digest);
  trust::PublicKey pub{};
  trust::derive_public_key(key_of(sender), pub);
  protocol::CloudSignature sig;
  trust::sign_cloud(key_of(sender), pub, frame, digest, static_cast<std::uint64_t>(kEpoch + kNow), sig);
  std::vector<std::uint8_t> d(protocol::signature_wire::kBytes);
  protocol::encode_signature_datagram(sig, d);
  return d;
}

__attribute__((noinline)) std::size_t receive_shares(firmware::InputDecoder& dec, const std::vector<Datagrams>& shares,
                                                     const std::vector<std::vector<std::uint8_t>>& sigs) {
  std::size_t queued = 0;
  for (std::size_t k = 0; k < shares.size(); ++k) {
    dec.on_datagram(sigs[k], kNow);
    for (const auto& f : shares[k]) {
      if (dec.on_datagram(f, kNow)) queued += dec.decode_completed().kind == firmware::CloudKind::kMapQueued;
    }
  }
  return queued;
}

__attribute__((noinline)) std::size_t close_period(firmware::InputDecoder& dec, const Datagrams& ego, std::int64_t now) {
  for (const auto& f : ego) {
    if (dec.on_datagram(f, now)) dec.decode_completed();
  }
  std::size_t fused = 0;
  for (std::size_t k = 0; k < firmware::kMaxSignatureVerificationsPerPeriod; ++k) {
    const firmware::DecodedCloud share = dec.next_verified_share();
    if (share.kind == firmware::CloudKind::kNone) break;
    fused += share.kind == firmware::CloudKind::kMapCloud;
  }
  return fused;
}

}  // namespace

int main() {
  auto dec = std::make_unique<firmware::InputDecoder>(kEpoch);
  trust::TrustList list;
  std::vector<Datagrams> shares;
  std::vector<std::vector<std::uint8_t>> sigs;
  for (std::uint32_t k = 0; k < kSources; ++k) {
    const std::uint32_t sender = firmware::kInfraSenderBase + k;
    trust::TrustedSigner& s = list.signers[list.count++];
    trust::derive_public_key(key_of(sender), s.key);
    s.id = trust::hashed_id8(s.key);
    s.role = trust::SignerRole::kInfrastructure;
    s.sender_id = sender;
    shares.push_back(fragment(protocol::CloudMessageType::kMapShare, sender, kPoints));
    sigs.push_back(sign(shares.back(), sender));
  }
  dec->provision_trust(list);
  const std::size_t queued = receive_shares(*dec, shares, sigs);
  std::size_t fused = 0;
  for (std::uint32_t p = 1; p <= 4; ++p) {
    const std::int64_t now = kNow + 100'000'000 * p;
    fused += close_period(*dec, fragment(protocol::CloudMessageType::kEgoScan, firmware::kEgoSenderId, 2000, p, now), now);
  }
  std::printf("sources %u points %zu fragments/share %zu queued %zu dropped %llu verified %llu fused %zu\n", kSources,
              kPoints, shares[0].size(), queued, (unsigned long long)dec->shares().counters().shares_queue_dropped,
              (unsigned long long)dec->shares().counters().signature_verifications, fused);
  return fused == queued - dec->shares().counters().shares_queue_dropped ? 0 : 1;
}
