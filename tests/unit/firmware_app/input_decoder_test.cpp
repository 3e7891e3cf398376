// InputDecoder, the three parts together as the period driver sees them: CAN frames to the CAN
// decoder, datagrams through the reassembly, signatures and map shares on to the verification
// queue, and an ego scan as the period boundary that carries the GNSS flag. (Each part has its own
// tests: can_input_decoder_test, cloud_input_decoder_test, share_verification_queue_test.)
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "decoded_log.hpp"
#include "share_signing.hpp"
#include "test_clouds.hpp"

namespace v2xloc::firmware {
namespace {

using test::fragment_cloud;
using test::kEpoch;
using test::ramp_points;

// An ego scan of 50 points stamped and received at now_ns; what the decoder made of it.
DecodedCloud ego_scan(InputDecoder& dec, std::uint32_t seq, std::int64_t now_ns, std::int64_t stamp_ns) {
  const auto ego = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, seq, stamp_ns, ramp_points(50));
  bool done = false;
  for (const auto& f : ego) done = dec.on_datagram(f, now_ns);
  EXPECT_TRUE(done);
  return dec.decode_completed();
}

TEST(InputDecoder, MapSharesCarrySourceIdAgentFlagAndPose) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  const std::vector<float> xyz = ramp_points(300);
  // Source id and role come from the provisioned trust list (the header's id must match it).
  trust::TrustList list;
  test::add_signer(list, kInfraSenderBase + 2, trust::SignerRole::kInfrastructure);
  test::add_signer(list, kAgentSenderBase + 1, trust::SignerRole::kAgent);
  dec->provision_trust(list);
  for (std::uint32_t sender : {kInfraSenderBase + 2, kAgentSenderBase + 1}) {
    const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, 500'000'000, xyz, {});
    EXPECT_FALSE(dec->on_datagram(test::sign_share(frags, sender, kEpoch + 500'000'000), 500'000'000));
    bool done = false;
    for (const auto& f : frags) done = dec->on_datagram(f, 500'000'000);
    ASSERT_TRUE(done);
    EXPECT_EQ(decoded.cloud(*dec), CloudKind::kMapCloud);
  }
  ASSERT_EQ(decoded.map.size(), 2u);
  EXPECT_EQ(decoded.map[0].source_id, 3u);
  EXPECT_FALSE(decoded.map[0].is_agent);
  EXPECT_EQ(decoded.map[1].source_id, 33u);
  EXPECT_TRUE(decoded.map[1].is_agent);
  EXPECT_DOUBLE_EQ(decoded.map[1].t, 0.5);
  EXPECT_DOUBLE_EQ(decoded.map[1].world_T_sensor(2, 3), 5.0);
  EXPECT_EQ(decoded.map_points[1].size(), 300u);
  EXPECT_EQ(dec->shares().counters().map_clouds, 2u);
  EXPECT_EQ(dec->shares().verifier().counters().accepted, 2u);

  // The same share again (replay), and one without a signature: refused, counted, not returned.
  for (bool sign : {true, false}) {
    const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase + 2, sign ? 1 : 2,
                                      500'000'000, xyz, {});
    if (sign) dec->on_datagram(test::sign_share(frags, kInfraSenderBase + 2, kEpoch + 500'000'000), 500'000'000);
    bool done = false;
    for (const auto& f : frags) done = dec->on_datagram(f, 500'000'000);
    ASSERT_TRUE(done);
    EXPECT_EQ(decoded.cloud(*dec), CloudKind::kRejected);
  }
  EXPECT_EQ(decoded.map.size(), 2u);
  EXPECT_EQ(dec->shares().verifier().counters().replay, 1u);
  EXPECT_EQ(dec->shares().verifier().counters().missing_signature, 1u);
  EXPECT_EQ(dec->shares().counters().shares_untrusted, 2u);
}

// More sources than the queue holds complete a share in the same period: the queue keeps the newest
// kShareVerifyQueueCapacity (the oldest are dropped and counted), and each ego scan (period
// boundary) verifies at most kMaxSignatureVerificationsPerPeriod of them, oldest first. A share is
// judged by the local clock when it completed, so one verified two periods (or 1.2 s) later still
// passes; fragments that differ from the signed wire bytes fail.
TEST(InputDecoder, SignatureChecksAreBoundedPerPeriodAndQueued) {
  static_assert(kMaxSignatureVerificationsPerPeriod == 2 && kShareVerifyQueueCapacity == 8);
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  trust::TrustList list;
  constexpr std::uint32_t kSources = kShareVerifyQueueCapacity + 2;
  constexpr std::uint32_t kTampered = kSources - 1;
  for (std::uint32_t k = 0; k < kSources; ++k) test::add_signer(list, kInfraSenderBase + k, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  const std::vector<float> xyz = ramp_points(400);
  std::vector<float> tampered = xyz;
  tampered[3 * 399] += 0.01f;  // 5 quantization steps: different wire bytes, same header
  ASSERT_EQ(ego_scan(*dec, 0, 400'000'000, 400'000'000).kind, CloudKind::kEgoScan);
  for (std::uint32_t k = 0; k < kSources; ++k) {
    const std::uint32_t sender = kInfraSenderBase + k;
    const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, 500'000'000, xyz, {});
    ASSERT_GT(frags.size(), 1u);
    dec->on_datagram(test::sign_share(frags, sender, kEpoch + 500'000'000), 500'000'000);
    // The last source sends fragments that are not the ones it signed; the rest arrive in reverse order.
    const auto sent = k == kTampered ? fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, 500'000'000, tampered, {})
                             : frags;
    bool done = false;
    for (auto it = sent.rbegin(); it != sent.rend(); ++it) done = dec->on_datagram(*it, 500'000'000);
    ASSERT_TRUE(done);
    EXPECT_EQ(dec->decode_completed().kind, CloudKind::kMapQueued) << k;
  }
  EXPECT_EQ(dec->shares().counters().shares_queued, kSources);
  EXPECT_EQ(dec->shares().counters().shares_queue_dropped, 2u);  // sources 0 and 1, the oldest
  EXPECT_EQ(dec->shares().shares_waiting(), kShareVerifyQueueCapacity);
  EXPECT_EQ(dec->shares().verifier().counters().accepted, 0u) << "no ECDSA before the period boundary";

  std::vector<std::uint32_t> fused;
  std::size_t rejected = 0;
  const auto period = [&](std::uint32_t seq, std::int64_t now_ns) {
    const auto ego = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, seq, now_ns, ramp_points(50), {});
    bool done = false;
    for (const auto& f : ego) done = dec->on_datagram(f, now_ns);
    EXPECT_TRUE(done);
    EXPECT_EQ(dec->decode_completed().kind, CloudKind::kEgoScan);
    std::size_t verified = 0;
    for (std::size_t guard = 0; guard < 10; ++guard) {
      const DecodedCloud share = dec->next_verified_share();
      if (share.kind == CloudKind::kNone) break;
      ++verified;
      if (share.kind == CloudKind::kMapCloud) {
        fused.push_back(share.map.source_id);
        EXPECT_EQ(share.map.points.size(), 400u);
        EXPECT_DOUBLE_EQ(share.map.t, 0.5);  // the share's own time, not the verification's
      } else {
        ++rejected;
      }
    }
    return verified;
  };
  EXPECT_EQ(period(1, 600'000'000), kMaxSignatureVerificationsPerPeriod);
  EXPECT_EQ(dec->shares().shares_waiting(), kShareVerifyQueueCapacity - 2);
  // 1.2 s and more after completion (beyond the 1 s freshness window by the clock now): still
  // judged by the completion time.
  EXPECT_EQ(period(2, 1'700'000'000), kMaxSignatureVerificationsPerPeriod);
  EXPECT_EQ(period(3, 1'800'000'000), kMaxSignatureVerificationsPerPeriod);
  EXPECT_EQ(period(4, 1'900'000'000), kMaxSignatureVerificationsPerPeriod);
  EXPECT_EQ(period(5, 2'000'000'000), 0u);
  std::vector<std::uint32_t> expected;
  for (std::uint32_t k = 2; k < kTampered; ++k) expected.push_back(kInfraSenderBase + k);
  EXPECT_EQ(fused, expected);
  EXPECT_EQ(rejected, 1u);
  EXPECT_EQ(dec->shares().verifier().counters().bad_signature, 1u);
  EXPECT_EQ(dec->shares().verifier().counters().accepted, kShareVerifyQueueCapacity - 1);
  EXPECT_EQ(dec->shares().counters().signature_verifications, kShareVerifyQueueCapacity);
  EXPECT_EQ(dec->shares().counters().shares_untrusted, 1u);
}

// The GNSS flag of a scan is the CAN side's: set when a fix was decoded since the previous scan
// used. Every ego scan, used or refused for its time, opens a period: the queued share is released
// after a refused one too, judged by its clock.
TEST(InputDecoder, EgoScansCarryTheGnssFlagAndOpenPeriods) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  trust::TrustList list;
  test::add_signer(list, kInfraSenderBase, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  protocol::GnssStatus status;
  status.fix_type = protocol::GnssFixType::kFix3D;
  EXPECT_EQ(dec->decode_can(protocol::pack(status), kEpoch + 50'000'000).kind, CanInputKind::kGnssPart);
  EXPECT_EQ(dec->decode_can(protocol::pack(protocol::GnssTime{100.0, 2300, 0}), kEpoch + 50'000'000).kind,
            CanInputKind::kGnssFix);

  const DecodedCloud first = ego_scan(*dec, 0, 100'000'000, 100'000'000);
  ASSERT_EQ(first.kind, CloudKind::kEgoScan);
  EXPECT_TRUE(first.gnss_used);
  EXPECT_EQ(first.frame_index, 0u);

  const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, 0, 150'000'000, ramp_points(80));
  EXPECT_FALSE(dec->on_datagram(test::sign_share(frags, kInfraSenderBase, kEpoch + 150'000'000), 150'000'000));
  bool done = false;
  for (const auto& f : frags) done = dec->on_datagram(f, 150'000'000);
  ASSERT_TRUE(done);
  EXPECT_EQ(dec->decode_completed().kind, CloudKind::kMapQueued);

  const DecodedCloud refused = ego_scan(*dec, 1, 200'000'000, 5'000'000'000);
  EXPECT_EQ(refused.kind, CloudKind::kEgoRejected);
  EXPECT_EQ(refused.frame_index, 1u);
  const DecodedCloud share = dec->next_verified_share();
  ASSERT_EQ(share.kind, CloudKind::kMapCloud) << "the refused scan opened the period";
  EXPECT_EQ(share.map.points.size(), 80u);
  EXPECT_GT(dec->take_trust_work(), kShareVerifyInstructions) << "hashing and the ECDSA";

  const DecodedCloud next = ego_scan(*dec, 2, 300'000'000, 300'000'000);
  ASSERT_EQ(next.kind, CloudKind::kEgoScan);
  EXPECT_FALSE(next.gnss_used) << "the fix went with the first scan";
  EXPECT_EQ(next.frame_index, 2u);
  EXPECT_EQ(dec->can().counters().gnss_inputs, 1u);
  EXPECT_EQ(dec->clouds().counters().ego_scans, 2u);
  EXPECT_EQ(dec->clouds().counters().ego_time_rejected, 1u);
  EXPECT_EQ(dec->shares().counters().map_clouds, 1u);
}

TEST(WireConventions, SimTimeFrameRoundTrips) {
  const std::int64_t t = 123'456'789'012;
  const hal::CanFrame f = make_sim_time_frame(t);
  std::int64_t back = 0;
  ASSERT_TRUE(parse_sim_time_frame(f, back));
  EXPECT_EQ(back, t);
  hal::CanFrame other = f;
  other.id = 0x120;
  EXPECT_FALSE(parse_sim_time_frame(other, back));
  EXPECT_TRUE(sender_is_agent(kAgentSenderBase));
  EXPECT_FALSE(sender_is_agent(kInfraSenderBase + 30));
}

}  // namespace
}  // namespace v2xloc::firmware
