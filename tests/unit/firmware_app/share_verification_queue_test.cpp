// ShareVerificationQueue on its own: shares reassembled by a plain protocol reassembler (what the
// cloud decoder hands on) and period boundaries opened by the test. The share filter on arrival,
// the cheap trust checks, the per-period ECDSA budget, freshness judged by the first boundary after
// completion, need and surveyed background asked before the signature check, and the trust work
// reported for the period budget.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "firmware/wire/share_verification_queue.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "share_signing.hpp"
#include "test_clouds.hpp"

namespace v2xloc::firmware {
namespace {

using test::fragment_cloud;
using test::kEpoch;
using test::ramp_points;
using Datagrams = std::vector<std::vector<std::uint8_t>>;

// Hands the queue what the firmware's cloud decoder would: signature datagrams, every map-share
// fragment the reassembler places, and each completed share with its header's pose and time.
class ShareFeed {
 public:
  explicit ShareFeed(ShareVerificationQueue& queue) : queue_(queue) {}

  // The signature (empty: none), then `fragments` in order, at monotonic now_ns; the queue's answer
  // to the completed share (kNone: it did not complete).
  CloudKind send(const std::vector<std::uint8_t>& signature, const Datagrams& fragments, std::int64_t now_ns) {
    if (!signature.empty()) queue_.on_signature_datagram(signature, now_ns);
    CloudKind kind = CloudKind::kNone;
    for (const auto& f : fragments) {
      const protocol::CloudStatus s = reassembler_->push(f, now_ns);
      const protocol::AcceptedFragment& a = reassembler_->last_accepted();
      if (a.valid) queue_.on_share_fragment(a, localizer_time_s(static_cast<std::int64_t>(a.timestamp_ns), kEpoch));
      if (s != protocol::CloudStatus::kFrameComplete) continue;
      const protocol::ReassembledCloud& cloud = reassembler_->completed();
      Mat4d pose;
      EXPECT_TRUE(sensor_pose_matrix(cloud.info.pose, pose));
      kind = queue_.queue(cloud, pose, localizer_time_s(static_cast<std::int64_t>(cloud.info.timestamp_ns), kEpoch)).kind;
    }
    return kind;
  }
  // A share of `xyz` from `sender` generated and received at now_ns, signed by the sender.
  CloudKind send_signed(std::uint32_t sender, std::int64_t now_ns, const std::vector<float>& xyz, std::uint32_t seq = 0) {
    const Datagrams frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, seq, now_ns, xyz);
    return send(test::sign_share(frags, sender, static_cast<std::uint64_t>(kEpoch + now_ns)), frags, now_ns);
  }

 private:
  ShareVerificationQueue& queue_;
  std::unique_ptr<protocol::StaticPointCloudReassembler<kReassemblySlots, 4096, 64>> reassembler_ =
      std::make_unique<protocol::StaticPointCloudReassembler<kReassemblySlots, 4096, 64>>();
};

trust::TrustList infrastructure_signers(std::uint32_t count) {
  trust::TrustList list;
  for (std::uint32_t k = 0; k < count; ++k) test::add_signer(list, kInfraSenderBase + k, trust::SignerRole::kInfrastructure);
  return list;
}

// The same with one agent (kAgentSenderBase) beside the units.
trust::TrustList infrastructure_and_agent_signers(std::uint32_t count) {
  trust::TrustList list = infrastructure_signers(count);
  test::add_signer(list, kAgentSenderBase, trust::SignerRole::kAgent);
  return list;
}

// The source ids of the shares this period releases, each verified and fused.
std::vector<std::uint32_t> fused_sources(ShareVerificationQueue& queue, const MapShareWanted* wanted) {
  std::vector<std::uint32_t> fused;
  for (std::size_t guard = 0; guard < 10; ++guard) {
    const DecodedCloud share = queue.next_verified_share(wanted);
    if (share.kind == CloudKind::kNone) break;
    EXPECT_EQ(share.kind, CloudKind::kMapCloud);
    fused.push_back(share.map.source_id);
  }
  return fused;
}

// The cheap checks refuse at completion, before the queue: no signature, an unknown signer, and a
// cloud outside the reassembler's geometry (which it never produces: the queue's storage is indexed by it).
TEST(ShareVerificationQueue, UnsignedUnknownOrMalformedSharesAreNotQueued) {
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  queue->provision_trust(infrastructure_signers(1));
  const std::vector<float> xyz = ramp_points(100);
  EXPECT_EQ(feed.send({}, fragment_cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, 0, 0, xyz), 0),
            CloudKind::kRejected);
  EXPECT_EQ(feed.send_signed(kInfraSenderBase + 5, 0, xyz), CloudKind::kRejected) << "not on the trust list";
  protocol::ReassembledCloud outside;
  outside.slot = kReassemblySlots;
  EXPECT_EQ(queue->queue(outside, Mat4d::Identity(), 0.0).kind, CloudKind::kRejected);
  EXPECT_EQ(queue->counters().shares_untrusted, 2u);
  EXPECT_EQ(queue->counters().shares_malformed, 1u);
  EXPECT_EQ(queue->verifier().counters().missing_signature, 1u);
  EXPECT_EQ(queue->verifier().counters().unknown_signer, 1u);
  EXPECT_EQ(queue->counters().shares_queued, 0u);
  EXPECT_EQ(queue->shares_waiting(), 0u);
  queue->begin_period(kEpoch + 100'000'000);
  EXPECT_EQ(queue->next_verified_share().kind, CloudKind::kNone);
  EXPECT_EQ(queue->counters().signature_verifications, 0u);
}

// A share is judged fresh by the first period boundary after it completed, however late it is
// released; one whose first boundary comes after its freshness window is refused without ECDSA.
TEST(ShareVerificationQueue, FreshnessIsJudgedByTheFirstBoundaryAfterCompletion) {
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  queue->provision_trust(infrastructure_signers(3));
  const std::vector<float> xyz = ramp_points(100);
  queue->begin_period(kEpoch + 400'000'000);
  ASSERT_EQ(feed.send_signed(kInfraSenderBase, 500'000'000, xyz), CloudKind::kMapQueued);
  ASSERT_EQ(feed.send_signed(kInfraSenderBase + 1, 500'000'000, xyz), CloudKind::kMapQueued);
  queue->begin_period(kEpoch + 600'000'000);  // judges both; nothing released in this period
  queue->begin_period(kEpoch + 2'000'000'000);  // 1.5 s after generation: past the 1 s window
  EXPECT_EQ(fused_sources(*queue, nullptr), (std::vector<std::uint32_t>{kInfraSenderBase, kInfraSenderBase + 1}));
  EXPECT_EQ(queue->verifier().counters().too_old, 0u);

  ASSERT_EQ(feed.send_signed(kInfraSenderBase + 2, 2'100'000'000, xyz), CloudKind::kMapQueued);
  queue->begin_period(kEpoch + 3'200'000'000);  // its first boundary: 1.1 s after generation
  EXPECT_EQ(queue->next_verified_share().kind, CloudKind::kNone) << "refused for its time: not returned";
  EXPECT_EQ(queue->verifier().counters().too_old, 1u);
  EXPECT_EQ(queue->counters().shares_untrusted, 1u);
  EXPECT_EQ(queue->counters().signature_verifications, 2u) << "no ECDSA for the stale share";
}

// Shares the map would not fuse (the localizer paces each source, reference_map.hpp) are skipped
// before their signature check: no ECDSA spent, counted, and the period's budget goes to the next.
TEST(ShareVerificationQueue, SharesTheMapDoesNotWantCostNoSignatureCheck) {
  struct EverySecondSender final : MapShareWanted {
    bool wants(std::uint32_t source_id, double t) const override {
      EXPECT_DOUBLE_EQ(t, 0.5);
      return (source_id - kInfraSenderBase) % 2 == 0;
    }
  };
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  constexpr std::uint32_t kSources = 4;
  queue->provision_trust(infrastructure_signers(kSources));
  const std::vector<float> xyz = ramp_points(100);
  queue->begin_period(kEpoch + 400'000'000);
  for (std::uint32_t k = 0; k < kSources; ++k) {
    ASSERT_EQ(feed.send_signed(kInfraSenderBase + k, 500'000'000, xyz), CloudKind::kMapQueued) << k;
  }
  queue->begin_period(kEpoch + 600'000'000);
  const EverySecondSender wanted;
  EXPECT_EQ(fused_sources(*queue, &wanted), (std::vector<std::uint32_t>{kInfraSenderBase, kInfraSenderBase + 2}));
  EXPECT_EQ(queue->counters().shares_paced, 1u);
  EXPECT_EQ(queue->counters().signature_verifications, 2u);
  EXPECT_EQ(queue->shares_waiting(), 1u) << "the budget is spent: the last share waits for the next period";
}

// With a share filter, a share the map would not fuse is decided on its first fragment: none of its
// fragments is hashed, it completes as kMapPaced (counted) and costs no signature check; a wanted
// share is hashed, queued and verified. The trust work (hashing, ECDSA) is reported once per period.
TEST(ShareVerificationQueue, UnwantedSharesAreNotHashedAndTrustWorkIsReported) {
  struct OnlyEvenSenders final : MapShareWanted {
    bool wants(std::uint32_t source_id, double t) const override {
      EXPECT_DOUBLE_EQ(t, 0.5);  // the header's time, as the queue would judge it
      ++asked;
      return (source_id - kInfraSenderBase) % 2 == 0;
    }
    mutable int asked = 0;
  };
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  const OnlyEvenSenders wanted;
  queue->set_share_filter(&wanted);
  queue->provision_trust(infrastructure_signers(2));
  const std::vector<float> xyz = ramp_points(400);
  std::size_t hashed_bytes = 0;
  queue->begin_period(kEpoch + 400'000'000);
  for (std::uint32_t k = 0; k < 2; ++k) {
    const std::uint32_t sender = kInfraSenderBase + k;
    const Datagrams frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, 500'000'000, xyz);
    ASSERT_GT(frags.size(), 1u);
    if (k == 0) {
      for (const auto& f : frags) {
        hashed_bytes += f.size() - protocol::pointcloud_wire::kHeaderBytes - protocol::pointcloud_wire::kTrailerBytes;
      }
    }
    const auto signature = test::sign_share(frags, sender, kEpoch + 500'000'000);
    EXPECT_EQ(feed.send(signature, frags, 500'000'000), k == 0 ? CloudKind::kMapQueued : CloudKind::kMapPaced) << k;
  }
  EXPECT_EQ(wanted.asked, 2) << "asked once per share, on its first fragment";
  EXPECT_EQ(queue->counters().shares_paced_on_arrival, 1u);
  EXPECT_EQ(queue->counters().shares_queued, 1u);
  const double hashing = kShareHashInstructionsPerByte * static_cast<double>(hashed_bytes);
  EXPECT_DOUBLE_EQ(queue->take_trust_work(), hashing) << "only the wanted share's fragments were hashed";
  EXPECT_DOUBLE_EQ(queue->take_trust_work(), 0.0) << "reported once";

  queue->begin_period(kEpoch + 600'000'000);
  const DecodedCloud share = queue->next_verified_share(&wanted);
  ASSERT_EQ(share.kind, CloudKind::kMapCloud);
  EXPECT_EQ(share.map.source_id, kInfraSenderBase);
  EXPECT_EQ(share.map.points.size(), 400u);
  EXPECT_EQ(queue->next_verified_share(&wanted).kind, CloudKind::kNone);
  EXPECT_EQ(queue->counters().signature_verifications, 1u);
  EXPECT_DOUBLE_EQ(queue->take_trust_work(), kShareVerifyInstructions);
}

// An infrastructure share the map would refuse as off its surveyed background is refused before
// its ECDSA: counted, and its place in the period goes to the next share. Agents are not asked.
TEST(ShareVerificationQueue, SharesOffTheirBackgroundCostNoSignatureCheck) {
  struct SecondUnitIsOff final : MapShareWanted {
    bool wants(std::uint32_t, double) const override { return true; }
    bool fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor,
                         std::span<const Vec3f> points) const override {
      EXPECT_EQ(points.size(), 100u);
      EXPECT_DOUBLE_EQ(world_T_sensor(0, 3), 9.5);
      asked.push_back(source_id);
      return source_id != kInfraSenderBase + 1;
    }
    mutable std::vector<std::uint32_t> asked;
  };
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  queue->provision_trust(infrastructure_and_agent_signers(3));
  const std::vector<float> xyz = ramp_points(100);
  queue->begin_period(kEpoch + 400'000'000);
  for (const std::uint32_t sender : {kInfraSenderBase + 1, kAgentSenderBase, kInfraSenderBase, kInfraSenderBase + 2}) {
    ASSERT_EQ(feed.send_signed(sender, 500'000'000, xyz), CloudKind::kMapQueued) << sender;
  }
  queue->begin_period(kEpoch + 600'000'000);
  const SecondUnitIsOff wanted;
  static_assert(kMaxSignatureVerificationsPerPeriod == 2);
  EXPECT_EQ(fused_sources(*queue, &wanted), (std::vector<std::uint32_t>{kAgentSenderBase, kInfraSenderBase}));
  EXPECT_EQ(wanted.asked, (std::vector<std::uint32_t>{kInfraSenderBase + 1, kInfraSenderBase}));
  EXPECT_EQ(queue->counters().shares_off_background, 1u);
  EXPECT_EQ(queue->counters().signature_verifications, 2u);
  EXPECT_EQ(queue->shares_waiting(), 1u) << "the budget is spent: the last share waits for the next period";
}

// A released infrastructure share says its filter found it on its background, so map fusion does
// not score the same points again; an agent's (never asked) and a share released without a filter
// do not.
TEST(ShareVerificationQueue, ASharesBackgroundVerdictTravelsWithIt) {
  struct Fits final : MapShareWanted {
    bool wants(std::uint32_t, double) const override { return true; }
    bool fits_background(std::uint32_t, const Mat4d&, std::span<const Vec3f>) const override { return true; }
  };
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  queue->provision_trust(infrastructure_and_agent_signers(1));
  const std::vector<float> xyz = ramp_points(100);
  queue->begin_period(kEpoch + 400'000'000);
  ASSERT_EQ(feed.send_signed(kInfraSenderBase, 500'000'000, xyz), CloudKind::kMapQueued);
  ASSERT_EQ(feed.send_signed(kAgentSenderBase, 500'000'000, xyz), CloudKind::kMapQueued);
  queue->begin_period(kEpoch + 600'000'000);
  const Fits wanted;
  std::vector<std::pair<std::uint32_t, bool>> released;
  for (DecodedCloud share = queue->next_verified_share(&wanted); share.kind == CloudKind::kMapCloud;
       share = queue->next_verified_share(&wanted)) {
    released.emplace_back(share.map.source_id, share.map.background_fits);
  }
  EXPECT_EQ(released, (std::vector<std::pair<std::uint32_t, bool>>{{kInfraSenderBase, true}, {kAgentSenderBase, false}}));

  auto plain = std::make_unique<ShareVerificationQueue>();
  ShareFeed plain_feed(*plain);
  plain->provision_trust(infrastructure_and_agent_signers(1));
  plain->begin_period(kEpoch + 400'000'000);
  ASSERT_EQ(plain_feed.send_signed(kInfraSenderBase, 500'000'000, xyz), CloudKind::kMapQueued);
  plain->begin_period(kEpoch + 600'000'000);
  const DecodedCloud unfiltered = plain->next_verified_share(nullptr);
  ASSERT_EQ(unfiltered.kind, CloudKind::kMapCloud);
  EXPECT_FALSE(unfiltered.map.background_fits) << "no filter asked: map fusion scores it";
}

// Until the localizer has a map, a share's ECDSA runs as it completes, at most
// kMaxSignatureVerificationsPerPeriod a period (before the first period boundary: every share); the
// period that fuses it releases it on the same schedule as ever without verifying it again (a share
// whose signature failed is still refused then), and charges it to its budget as ever.
TEST(ShareVerificationQueue, SignaturesAreCheckedOnArrivalUntilTheFirstMap) {
  struct MapPending final : MapShareWanted {
    bool wants(std::uint32_t, double) const override { return true; }
    bool awaiting_first_map() const override { return pending; }
    bool pending = true;
  };
  static_assert(kMaxSignatureVerificationsPerPeriod == 2);
  auto queue = std::make_unique<ShareVerificationQueue>();
  ShareFeed feed(*queue);
  MapPending map_pending;
  queue->set_share_filter(&map_pending);
  queue->provision_trust(infrastructure_signers(5));
  const std::vector<float> xyz = ramp_points(100);
  std::vector<float> tampered = xyz;
  tampered[3 * 99] += 0.01f;  // 5 quantization steps: different wire bytes, same header
  const auto send = [&](std::uint32_t k, std::int64_t now_ns, bool tamper, std::uint32_t seq = 0) {
    const std::uint32_t sender = kInfraSenderBase + k;
    const Datagrams frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, seq, now_ns, xyz);
    const Datagrams sent =
        tamper ? fragment_cloud(protocol::CloudMessageType::kMapShare, sender, seq, now_ns, tampered) : frags;
    ASSERT_EQ(feed.send(test::sign_share(frags, sender, kEpoch + now_ns), sent, now_ns), CloudKind::kMapQueued) << k;
  };
  const auto release_all = [&] {
    std::vector<CloudKind> released;
    for (std::size_t guard = 0; guard < 10; ++guard) {
      const DecodedCloud share = queue->next_verified_share(&map_pending);
      if (share.kind == CloudKind::kNone) break;
      released.push_back(share.kind);
    }
    return released;
  };
  for (std::uint32_t k = 0; k < 3; ++k) send(k, 500'000'000, k == 0);
  EXPECT_EQ(queue->counters().signatures_checked_on_arrival, 3u) << "before the first boundary: all";
  EXPECT_EQ(queue->counters().signature_verifications, 3u);
  EXPECT_EQ(queue->verifier().counters().accepted, 0u) << "accepted only at a period boundary";

  queue->begin_period(kEpoch + 600'000'000);
  EXPECT_GT(queue->take_trust_work(), 0.0) << "the shares' hashing";
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kRejected, CloudKind::kMapCloud}));
  EXPECT_EQ(queue->verifier().counters().bad_signature, 1u);
  EXPECT_EQ(queue->counters().signature_verifications, 3u) << "none verified twice";
  EXPECT_DOUBLE_EQ(queue->take_trust_work(), 2 * kShareVerifyInstructions) << "charged where released, as ever";

  send(3, 650'000'000, false);  // still no map: checked on arrival (two a period)
  send(4, 650'000'000, false);
  EXPECT_EQ(queue->counters().signatures_checked_on_arrival, 5u);
  map_pending.pending = false;
  send(0, 660'000'000, false, 1);  // the map exists: verified at its release, as ever
  EXPECT_EQ(queue->counters().signatures_checked_on_arrival, 5u);
  EXPECT_EQ(queue->counters().signature_verifications, 5u);
  queue->begin_period(kEpoch + 700'000'000);
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kMapCloud, CloudKind::kMapCloud}));
  EXPECT_EQ(queue->shares_waiting(), 2u);
  EXPECT_EQ(queue->counters().signature_verifications, 5u) << "all released ones were checked on arrival";
  queue->begin_period(kEpoch + 800'000'000);
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kMapCloud, CloudKind::kMapCloud}));
  EXPECT_EQ(queue->counters().signature_verifications, 6u) << "the last one, sent with a map, verified at release";
}

}  // namespace
}  // namespace v2xloc::firmware
