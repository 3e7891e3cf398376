// CloudInputDecoder: datagrams checked against their endpoint, reassembled, and the completed
// cloud checked (pose, sender, size): an ego scan dequantized once its time stamp is plausible, a
// map share handed on as it arrived. Malformed or truncated input is counted and never disturbs
// the clouds around it.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "firmware/protocol/cloud_signature.hpp"
#include "firmware/wire/cloud_input_decoder.hpp"
#include "decoded_log.hpp"
#include "share_signing.hpp"
#include "test_clouds.hpp"

namespace v2xloc::firmware {
namespace {

using test::fragment_cloud;
using test::kEpoch;
using test::ramp_points;

// A datagram on the endpoint its type belongs on, received at now_ns (local clock kEpoch + now_ns).
bool push(CloudInputDecoder& dec, const std::vector<std::uint8_t>& datagram, std::int64_t now_ns) {
  return dec.on_datagram(datagram, now_ns, kEpoch + now_ns, CloudInputDecoder::channel_of(datagram)).completed;
}

// One ego scan (a single fragment) stamped kEpoch + stamp_ns, received when the local clock reads
// kEpoch + local_ns; what it decoded to.
DecodedCloud ego_scan(CloudInputDecoder& dec, std::uint32_t seq, std::int64_t stamp_ns, std::int64_t local_ns) {
  const auto frags = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, seq, stamp_ns, ramp_points(20));
  EXPECT_EQ(frags.size(), 1u);
  EXPECT_TRUE(dec.on_datagram(frags[0], local_ns, kEpoch + local_ns, DatagramChannel::kEgo).completed);
  return dec.decode_completed();
}

TEST(CloudInputDecoder, CloudsSurviveTruncatedCorruptAndDuplicateFragments) {
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  test::DecodedLog decoded;
  const std::vector<float> xyz = ramp_points(1000);
  std::vector<std::uint16_t> times;
  for (std::size_t i = 0; i < 1000; ++i) times.push_back(static_cast<std::uint16_t>(i * 50));
  const auto frags = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 7, 300'000'000, xyz, times);
  ASSERT_GT(frags.size(), 3u);

  // Truncated copy of fragment 1, a bit-flipped copy of fragment 2, then every fragment reversed
  // with a duplicate: the frame still completes once, the bad datagrams are counted.
  std::vector<std::uint8_t> truncated(frags[1].begin(), frags[1].begin() + 60);
  std::vector<std::uint8_t> flipped = frags[2];
  flipped[200] ^= 0x10;
  EXPECT_FALSE(push(*dec, truncated, 0));
  EXPECT_FALSE(push(*dec, flipped, 0));
  EXPECT_FALSE(push(*dec, frags[0], 0));
  EXPECT_FALSE(push(*dec, frags[0], 0));  // duplicate
  bool completed = false;
  for (std::size_t k = frags.size() - 1; k >= 1; --k) {
    completed = push(*dec, frags[k], 0);
    if (k > 1) {
      EXPECT_FALSE(completed);
    }
  }
  ASSERT_TRUE(completed);
  EXPECT_EQ(decoded.cloud(*dec), CloudKind::kEgoScan);
  EXPECT_EQ(decoded.cloud(*dec), CloudKind::kNone);  // returned once
  EXPECT_EQ(dec->counters().datagrams_rejected, 2u);
  EXPECT_EQ(dec->reassembly_counters().duplicates, 1u);
  EXPECT_EQ(dec->reassembly_counters().truncated + dec->reassembly_counters().bad_crc, 2u);

  ASSERT_EQ(decoded.ego.size(), 1u);
  EXPECT_DOUBLE_EQ(decoded.ego[0].t, 0.3);
  ASSERT_EQ(decoded.ego_points[0].size(), 1000u);
  ASSERT_EQ(decoded.ego_times[0].size(), 1000u);
  for (std::size_t i = 0; i < 1000; ++i) {
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(decoded.ego_points[0][i][a], xyz[3 * i + a], 0.5 * kCloudScaleM + 1e-5);
    EXPECT_FLOAT_EQ(decoded.ego_times[0][i], static_cast<float>(times[i] * protocol::kPointTimeTick));
  }
  EXPECT_DOUBLE_EQ(decoded.ego[0].body_T_lidar(0, 3), 9.5);
  EXPECT_EQ(decoded.ego_frame_index[0], 0u);
  EXPECT_FALSE(decoded.ego_gnss_used[0]) << "the GNSS flag is the CAN side's (InputDecoder sets it)";
}

TEST(CloudInputDecoder, EgoScanFromAnotherSenderIsRejectedAndCounted) {
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  test::DecodedLog decoded;
  const auto frags = fragment_cloud(protocol::CloudMessageType::kEgoScan, 5, 0, 0, ramp_points(10), {});
  ASSERT_EQ(frags.size(), 1u);
  ASSERT_TRUE(push(*dec, frags[0], 0));
  EXPECT_EQ(decoded.cloud(*dec), CloudKind::kRejected);
  EXPECT_EQ(dec->counters().clouds_rejected, 1u);
  EXPECT_TRUE(decoded.ego.empty());
}

// Ego scans only on the ego endpoint, map shares and signatures only on the V2X one: anything else
// is counted and never reaches the reassembler (or the share verifier).
TEST(CloudInputDecoder, DatagramsOnTheWrongEndpointAreRefused) {
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  const auto ego = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 0, 0, ramp_points(20));
  const auto share = fragment_cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, 0, 0, ramp_points(20));
  const auto signature = test::sign_share(share, kInfraSenderBase, static_cast<std::uint64_t>(kEpoch));
  ASSERT_EQ(ego.size(), 1u);
  ASSERT_EQ(share.size(), 1u);
  EXPECT_EQ(CloudInputDecoder::channel_of(ego[0]), DatagramChannel::kEgo);
  EXPECT_EQ(CloudInputDecoder::channel_of(share[0]), DatagramChannel::kV2x);
  EXPECT_EQ(CloudInputDecoder::channel_of(signature), DatagramChannel::kV2x);

  const DatagramResult ego_on_v2x = dec->on_datagram(ego[0], 0, kEpoch, DatagramChannel::kV2x);
  const DatagramResult share_on_ego = dec->on_datagram(share[0], 0, kEpoch, DatagramChannel::kEgo);
  const DatagramResult signature_on_ego = dec->on_datagram(signature, 0, kEpoch, DatagramChannel::kEgo);
  for (const DatagramResult& r : {ego_on_v2x, share_on_ego, signature_on_ego}) {
    EXPECT_FALSE(r.completed);
    EXPECT_FALSE(r.signature);
    EXPECT_EQ(r.share_fragment, nullptr);
  }
  EXPECT_EQ(dec->counters().wrong_channel, 3u);
  EXPECT_EQ(dec->reassembly_counters().fragments_accepted, 0u);
  EXPECT_EQ(dec->decode_completed().kind, CloudKind::kNone);

  const DatagramResult signature_on_v2x = dec->on_datagram(signature, 0, kEpoch, DatagramChannel::kV2x);
  EXPECT_TRUE(signature_on_v2x.signature) << "for the share verifier";
  EXPECT_FALSE(signature_on_v2x.completed);
  EXPECT_TRUE(dec->on_datagram(ego[0], 0, kEpoch, DatagramChannel::kEgo).completed);
  EXPECT_EQ(dec->decode_completed().kind, CloudKind::kEgoScan);
  EXPECT_EQ(dec->counters().datagrams, 5u);
  EXPECT_EQ(dec->counters().wrong_channel, 3u);
}

// An ego scan's stamp must be within kEgoScanMaxClockSkewNs of the local clock and newer than the
// last scan used. A refused scan still takes its frame index (a pose is published for every frame)
// and leaves no trace: the scans after it are judged as if it never came.
TEST(CloudInputDecoder, EgoScanTimeIsCheckedAgainstTheLocalClock) {
  static_assert(kEgoScanMaxClockSkewNs == 500'000'000);
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  const DecodedCloud stale = ego_scan(*dec, 0, 0, 600'000'000);
  EXPECT_EQ(stale.kind, CloudKind::kEgoRejected);
  EXPECT_EQ(stale.frame_index, 0u);
  EXPECT_EQ(dec->completed_local_time_ns(), kEpoch + 600'000'000);
  const DecodedCloud ahead = ego_scan(*dec, 1, 1'450'000'000, 1'000'000'000);
  EXPECT_EQ(ahead.kind, CloudKind::kEgoScan) << "within the skew";
  EXPECT_EQ(ahead.frame_index, 1u);
  EXPECT_DOUBLE_EQ(ahead.ego.t, 1.45);
  EXPECT_EQ(ahead.ego.points.size(), 20u);
  const DecodedCloud same_stamp = ego_scan(*dec, 2, 1'450'000'000, 1'100'000'000);
  EXPECT_EQ(same_stamp.kind, CloudKind::kEgoRejected) << "not newer than the last scan used";
  EXPECT_EQ(same_stamp.frame_index, 2u);
  const DecodedCloud future = ego_scan(*dec, 3, 1'700'000'000, 1'100'000'000);
  EXPECT_EQ(future.kind, CloudKind::kEgoRejected) << "600 ms ahead of the local clock";
  const DecodedCloud next = ego_scan(*dec, 4, 1'500'000'000, 1'500'000'000);
  EXPECT_EQ(next.kind, CloudKind::kEgoScan);
  EXPECT_EQ(next.frame_index, 4u);
  EXPECT_EQ(dec->counters().ego_time_rejected, 3u);
  EXPECT_EQ(dec->counters().ego_scans, 2u);
}

// A map share is not decoded here: every fragment is reported (for its hash) with the header's
// time, and the completed share comes back as kMapShare with its pose and time, the reassembled
// cloud left for the verification queue.
TEST(CloudInputDecoder, MapShareIsHandedOnAsItArrived) {
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, kAgentSenderBase, 3, 500'000'000, ramp_points(300));
  ASSERT_GT(frags.size(), 1u);
  bool completed = false;
  for (std::size_t k = 0; k < frags.size(); ++k) {
    const DatagramResult r = dec->on_datagram(frags[k], 0, kEpoch, DatagramChannel::kV2x);
    ASSERT_NE(r.share_fragment, nullptr) << k;
    EXPECT_EQ(r.share_fragment->opened_frame, k == 0) << k;
    EXPECT_EQ(r.share_fragment->sender_id, kAgentSenderBase);
    EXPECT_DOUBLE_EQ(r.share_t, 0.5);
    completed = r.completed;
  }
  ASSERT_TRUE(completed);
  const DecodedCloud share = dec->decode_completed();
  EXPECT_EQ(share.kind, CloudKind::kMapShare);
  EXPECT_DOUBLE_EQ(share.map.t, 0.5);
  EXPECT_DOUBLE_EQ(share.map.world_T_sensor(0, 3), 9.5);
  EXPECT_DOUBLE_EQ(share.map.world_T_sensor(2, 3), 5.0);
  EXPECT_TRUE(share.map.points.empty()) << "the points go straight into the queue's slot";
  EXPECT_EQ(dec->completed_cloud().point_count, 300u);
  EXPECT_EQ(dec->completed_cloud().info.frame_seq, 3u);
  EXPECT_EQ(dec->counters().clouds_rejected, 0u);
  EXPECT_EQ(dec->counters().ego_scans, 0u);

  const auto ego = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 0, 0, ramp_points(20));
  EXPECT_EQ(dec->on_datagram(ego[0], 0, kEpoch, DatagramChannel::kEgo).share_fragment, nullptr);
}

// A cloud whose sensor pose is not a rotation (or not finite) is unusable, whatever its type.
TEST(CloudInputDecoder, CloudWithoutAUsablePoseIsRejected) {
  auto dec = std::make_unique<CloudInputDecoder>(kEpoch);
  test::DecodedLog decoded;
  for (const protocol::CloudMessageType type : {protocol::CloudMessageType::kEgoScan, protocol::CloudMessageType::kMapShare}) {
    protocol::CloudFrameInfo info = test::cloud_info(type, type == protocol::CloudMessageType::kEgoScan ? kEgoSenderId : kInfraSenderBase, 0, 0);
    info.pose.quaternion_xyzw[3] = 2.0;
    const auto frags = test::fragment_frame(info, ramp_points(20));
    ASSERT_EQ(frags.size(), 1u);
    ASSERT_TRUE(push(*dec, frags[0], 0));
    EXPECT_EQ(decoded.cloud(*dec), CloudKind::kRejected);
  }
  EXPECT_EQ(dec->counters().clouds_rejected, 2u);
  EXPECT_TRUE(decoded.ego.empty());
  Mat4d m;
  protocol::SensorPose nan_position;
  nan_position.position_m[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(sensor_pose_matrix(nan_position, m));
  protocol::SensorPose turned;
  turned.quaternion_xyzw[2] = std::sqrt(0.5);
  turned.quaternion_xyzw[3] = std::sqrt(0.5);
  ASSERT_TRUE(sensor_pose_matrix(turned, m));
  EXPECT_NEAR(m(1, 0), 1.0, 1e-12) << "90 deg about z";
  EXPECT_DOUBLE_EQ(m(3, 3), 1.0);
}

}  // namespace
}  // namespace v2xloc::firmware
