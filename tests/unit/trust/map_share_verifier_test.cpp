// Map-share verifier: one accepted share, then every rejection reason with its counter, and the
// signature datagram codec (bit flips, sizes).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/trust/cloud_digest.hpp"
#include "firmware/trust/map_share_verifier.hpp"

namespace v2xloc::trust {
namespace {

constexpr std::int64_t kNow = 1'700'000'000'000'000'000;

PrivateKey key(const std::string& seed) {
  return private_key_from_seed(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()));
}

struct Fixture {
  PrivateKey infra_priv = key("infra"), agent_priv = key("agent"), rogue_priv = key("rogue");
  PublicKey infra_pub{}, agent_pub{}, rogue_pub{};
  TrustList list;
  std::vector<float> xyz;
  protocol::ReassembledCloud cloud;

  Fixture() {
    derive_public_key(infra_priv, infra_pub);
    derive_public_key(agent_priv, agent_pub);
    derive_public_key(rogue_priv, rogue_pub);
    add(infra_pub, SignerRole::kInfrastructure, 1);
    add(agent_pub, SignerRole::kAgent, 32);
    for (int i = 0; i < 300; ++i) xyz.insert(xyz.end(), {0.1f * i, -0.05f * i, 1.0f});
    cloud.info.type = protocol::CloudMessageType::kMapShare;
    cloud.info.sender_id = 1;
    cloud.info.frame_seq = 7;
    cloud.info.timestamp_ns = static_cast<std::uint64_t>(kNow - 5'000'000);
    cloud.info.pose.position_m[0] = 12.5;
    cloud.point_count = 300;
    cloud.xyz = xyz;
  }
  void add(const PublicKey& pub, SignerRole role, std::uint32_t id) {
    TrustedSigner& s = list.signers[list.count++];
    s.key = pub;
    s.id = hashed_id8(pub);
    s.role = role;
    s.sender_id = id;
  }
  // The cloud as datagrams (what a sender transmits), fragments of 40 points.
  std::vector<std::vector<std::uint8_t>> datagrams() const {
    protocol::PointCloudFragmenter fragmenter;
    EXPECT_EQ(fragmenter.begin(cloud.info, protocol::CloudPointsView{xyz, {}, {}}, 104 + 4 + 40 * 6), protocol::CloudStatus::kOk);
    std::vector<std::vector<std::uint8_t>> out;
    for (int guard = 0; guard < 100; ++guard) {
      std::vector<std::uint8_t> d(protocol::pointcloud_wire::kMaxDatagramBytes);
      std::size_t n = 0;
      if (fragmenter.next(d, n) != protocol::CloudStatus::kOk) break;
      d.resize(n);
      out.push_back(std::move(d));
    }
    return out;
  }
  // The cloud digest over the wire bytes, and the frame fields it covers.
  Digest digest(protocol::ReassembledCloud* frame_out = nullptr) const {
    const auto ds = datagrams();
    std::vector<ShareDigestBuilder::Entry> scratch(ds.size());
    ShareDigestBuilder builder(scratch);
    for (const auto& d : ds) EXPECT_TRUE(builder.add(d));
    protocol::ReassembledCloud frame;
    Digest out{};
    EXPECT_TRUE(builder.finish(frame, out));
    if (frame_out != nullptr) *frame_out = frame;
    return out;
  }
  std::array<std::uint8_t, protocol::signature_wire::kBytes> signed_datagram(const PrivateKey& priv, const PublicKey& pub,
                                                                             std::int64_t gen_ns) {
    protocol::CloudSignature sig;
    protocol::ReassembledCloud frame;
    const Digest d0 = digest(&frame);
    EXPECT_EQ(sign_cloud(priv, pub, frame, d0, static_cast<std::uint64_t>(gen_ns), sig), CryptoStatus::kOk);
    std::array<std::uint8_t, protocol::signature_wire::kBytes> d{};
    EXPECT_TRUE(encode_signature_datagram(sig, d));
    return d;
  }
};

TEST(MapShareVerifier, AcceptsASignedFreshShareAndNamesTheProvisionedRole) {
  Fixture f;
  MapShareVerifier v;
  v.provision(f.list);
  const auto d = f.signed_datagram(f.infra_priv, f.infra_pub, kNow - 1'000'000);
  ASSERT_EQ(v.on_signature_datagram(d, 0), protocol::SignatureParseStatus::kOk);
  const ShareVerifyResult r = v.verify(f.cloud.info, f.digest(), kNow);
  EXPECT_EQ(r.verdict, ShareVerdict::kAccepted);
  ASSERT_NE(r.signer, nullptr);
  EXPECT_EQ(r.signer->role, SignerRole::kInfrastructure);
  EXPECT_EQ(v.counters().accepted, 1u);
  EXPECT_EQ(v.counters().rejected(), 0u);
}

TEST(MapShareVerifier, EveryRejectionIsCountedByReason) {
  Fixture f;
  MapShareVerifier v;
  v.provision(f.list);
  std::int64_t gen = kNow - 1'000'000;
  const auto expect = [&](ShareVerdict want, const std::uint64_t& counter) {
    const std::uint64_t before = counter;
    EXPECT_EQ(v.verify(f.cloud.info, f.digest(), kNow).verdict, want) << to_string(want);
    EXPECT_EQ(counter, before + 1) << to_string(want);
  };
  const VerifierCounters& c = v.counters();
  // Unsigned.
  expect(ShareVerdict::kMissingSignature, c.missing_signature);
  // Signed by a key that is not provisioned.
  v.on_signature_datagram(f.signed_datagram(f.rogue_priv, f.rogue_pub, gen), 0);
  expect(ShareVerdict::kUnknownSigner, c.unknown_signer);
  // A provisioned agent key claiming an infrastructure sender id.
  v.on_signature_datagram(f.signed_datagram(f.agent_priv, f.agent_pub, gen), 0);
  expect(ShareVerdict::kSenderMismatch, c.sender_mismatch);
  // Too old / from the future by the local clock (the old cloud stamped as old as its signature:
  // the stamp-skew check runs first and needs no clock).
  const std::uint64_t stamp = f.cloud.info.timestamp_ns;
  f.cloud.info.timestamp_ns = static_cast<std::uint64_t>(kNow - 1'500'000'000);
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow - 1'500'000'000), 0);
  expect(ShareVerdict::kTooOld, c.too_old);
  f.cloud.info.timestamp_ns = stamp;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow + 41'000'000), 0);
  expect(ShareVerdict::kFuture, c.future);
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow + 39'000'000), 0);
  EXPECT_EQ(v.verify(f.cloud.info, f.digest(), kNow).verdict, ShareVerdict::kAccepted) << "39 ms ahead is inside the margin";
  // Replay of an accepted share (same generation time) and an older one.
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow + 39'000'000), 0);
  expect(ShareVerdict::kReplay, c.replay);
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen), 0);
  expect(ShareVerdict::kReplay, c.replay);
  // The cloud changed after signing: shifted pose (the rogue-shift attack), one point moved.
  gen = kNow + 39'500'000;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen), 0);
  f.cloud.info.pose.position_m[0] += 0.25;
  expect(ShareVerdict::kBadSignature, c.bad_signature);
  f.cloud.info.pose.position_m[0] -= 0.25;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen), 0);
  f.xyz[299 * 3 + 2] += 0.004f;
  expect(ShareVerdict::kBadSignature, c.bad_signature);
  f.xyz[299 * 3 + 2] -= 0.004f;
  // A cloud stamped far from its signature's generation time.
  f.cloud.info.timestamp_ns = static_cast<std::uint64_t>(kNow + 1'000'000'000);
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen), 0);
  expect(ShareVerdict::kStampSkew, c.stamp_skew);
  EXPECT_EQ(c.accepted, 1u);
}

// A surveyed infrastructure unit signing shares that declare its pose shifted 0.25 m, 3 m and 200 m
// (the rogue-shift insider: its own key, a valid signature): refused as kPoseMismatch before any
// ECDSA; its genuine share is accepted. Without a survey the same shifted share is accepted.
TEST(MapShareVerifier, SurveyedInfrastructureDeclaringAnotherPoseIsRefused) {
  for (const bool surveyed : {true, false}) {
    Fixture f;
    f.list.signers[0].surveyed = surveyed;
    f.list.signers[0].survey.position_m = {12.5, 0.0, 0.0};
    MapShareVerifier v;
    v.provision(f.list);
    std::int64_t gen = kNow - 30'000'000;
    for (const double shift : {0.25, 3.0, 200.0}) {
      f.cloud.info.pose.position_m[0] = 12.5 + shift;
      gen += 1'000'000;
      v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen), 0);  // signed as shifted
      const ShareVerdict want = surveyed ? ShareVerdict::kPoseMismatch : ShareVerdict::kAccepted;
      EXPECT_EQ(v.verify(f.cloud.info, f.digest(), kNow).verdict, want) << shift;
    }
    f.cloud.info.pose.position_m[0] = 12.5;
    v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, gen + 1'000'000), 0);
    EXPECT_EQ(v.verify(f.cloud.info, f.digest(), kNow).verdict, ShareVerdict::kAccepted);
    EXPECT_EQ(v.counters().pose_mismatch, surveyed ? 3u : 0u);
    EXPECT_EQ(v.counters().accepted, surveyed ? 1u : 4u);
    EXPECT_EQ(v.counters().rejected(), surveyed ? 3u : 0u);
  }
}

// admit(), check_time() then complete(), as the decoder's queue does: freshness is judged once, at
// the first period boundary, so a job completed later still passes; two jobs of one signer completed newest first leave the older one
// a replay (the replay check runs again at completion); the digest binds the wire bytes.
TEST(MapShareVerifier, AdmittedJobsAreCompletedLaterAndRecheckedForReplay) {
  Fixture f;
  MapShareVerifier v;
  v.provision(f.list);
  const Digest digest = f.digest();
  VerificationJob older, newer;
  f.cloud.info.frame_seq = 7;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow - 2'000'000), 0);
  ASSERT_EQ(v.admit(f.cloud.info, f.digest(), older).verdict, ShareVerdict::kAccepted);
  f.cloud.info.frame_seq = 8;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow - 1'000'000), 0);
  ASSERT_EQ(v.admit(f.cloud.info, f.digest(), newer).verdict, ShareVerdict::kAccepted);
  EXPECT_EQ(v.counters().accepted, 0u) << "admission runs no ECDSA";
  EXPECT_EQ(v.check_time(older, kNow).verdict, ShareVerdict::kAccepted);
  EXPECT_EQ(v.check_time(newer, kNow + 100'000'000).verdict, ShareVerdict::kAccepted);
  // The same jobs judged at a clock 1.1 s later, or 50 ms earlier than their generation: refused.
  EXPECT_EQ(v.check_time(older, kNow + 1'100'000'000).verdict, ShareVerdict::kTooOld);
  EXPECT_EQ(v.check_time(newer, kNow - 1'000'000 - 50'000'000).verdict, ShareVerdict::kFuture);
  EXPECT_EQ(v.counters().too_old, 1u);
  EXPECT_EQ(v.counters().future, 1u);
  EXPECT_EQ(v.complete(newer).verdict, ShareVerdict::kAccepted);
  EXPECT_EQ(v.complete(older).verdict, ShareVerdict::kReplay);
  EXPECT_EQ(v.counters().accepted, 1u);
  EXPECT_EQ(v.counters().replay, 1u);

  // One quantization step in one point changes the wire bytes, hence the digest.
  f.xyz[5] += 0.004f;
  EXPECT_NE(f.digest(), digest);
  f.xyz[5] -= 0.004f;
  // Arrival order does not matter: the builder fed in reverse gives the same digest.
  f.cloud.info.frame_seq = 7;
  auto ds = f.datagrams();
  ASSERT_GT(ds.size(), 2u);
  std::vector<ShareDigestBuilder::Entry> scratch(ds.size());
  ShareDigestBuilder builder(scratch);
  for (auto it = ds.rbegin(); it != ds.rend(); ++it) ASSERT_TRUE(builder.add(*it));
  protocol::ReassembledCloud frame;
  Digest reversed{};
  ASSERT_TRUE(builder.finish(frame, reversed));
  EXPECT_EQ(reversed, digest);
  // A missing fragment: no digest.
  ShareDigestBuilder partial(scratch);
  for (std::size_t i = 1; i < ds.size(); ++i) partial.add(ds[i]);
  EXPECT_FALSE(partial.finish(frame, reversed));
}

TEST(MapShareVerifier, EmptyTrustListAcceptsNothing) {
  Fixture f;
  MapShareVerifier v;
  v.on_signature_datagram(f.signed_datagram(f.infra_priv, f.infra_pub, kNow), 0);
  EXPECT_EQ(v.verify(f.cloud.info, f.digest(), kNow).verdict, ShareVerdict::kUnknownSigner);
}

TEST(MapShareVerifier, PendingSignaturesAreBoundedAndExpire) {
  Fixture f;
  MapShareVerifier v;
  v.provision(f.list);
  protocol::CloudSignature sig;
  std::array<std::uint8_t, protocol::signature_wire::kBytes> d{};
  for (std::uint32_t i = 0; i < MapShareVerifier::kPendingSignatures + 5; ++i) {
    sig.frame_seq = 1000 + i;
    encode_signature_datagram(sig, d);
    v.on_signature_datagram(d, i);
  }
  EXPECT_EQ(v.counters().signatures_evicted, 5u);
  v.expire(2'000'000'000);
  EXPECT_EQ(v.counters().signatures_expired, MapShareVerifier::kPendingSignatures);
}

TEST(CloudSignatureWire, RoundTripAndRejections) {
  protocol::CloudSignature s;
  s.sender_id = 0xA1B2C3D4;
  s.sensor_id = 0x1234;
  s.frame_seq = 42;
  s.generation_time_ns = 0x0102030405060708ull;
  for (std::size_t i = 0; i < 8; ++i) s.signer[i] = static_cast<std::uint8_t>(i + 1);
  for (std::size_t i = 0; i < 64; ++i) s.signature[i] = static_cast<std::uint8_t>(200 - i);
  std::array<std::uint8_t, protocol::signature_wire::kBytes + 1> buf{};
  ASSERT_TRUE(encode_signature_datagram(s, buf));
  protocol::CloudSignature back;
  const std::span<const std::uint8_t> d(buf.data(), protocol::signature_wire::kBytes);
  ASSERT_EQ(parse_signature_datagram(d, back), protocol::SignatureParseStatus::kOk);
  EXPECT_EQ(back.sender_id, s.sender_id);
  EXPECT_EQ(back.sensor_id, s.sensor_id);
  EXPECT_EQ(back.generation_time_ns, s.generation_time_ns);
  EXPECT_EQ(back.signer, s.signer);
  EXPECT_EQ(back.signature, s.signature);
  EXPECT_EQ(parse_signature_datagram(std::span<const std::uint8_t>(buf), back), protocol::SignatureParseStatus::kWrongSize);
  for (std::size_t n = 0; n < protocol::signature_wire::kBytes; ++n) {
    const protocol::SignatureParseStatus st = parse_signature_datagram(d.first(n), back);
    EXPECT_TRUE(st == protocol::SignatureParseStatus::kWrongSize || st == protocol::SignatureParseStatus::kNotSignature);
  }
  for (const std::size_t byte : {4u, 5u, 6u, 7u, 14u, 15u}) {
    auto bad = buf;
    bad[byte] ^= 1;
    EXPECT_EQ(parse_signature_datagram(std::span<const std::uint8_t>(bad.data(), protocol::signature_wire::kBytes), back),
              protocol::SignatureParseStatus::kUnsupported)
        << byte;
  }
}

}  // namespace
}  // namespace v2xloc::trust
