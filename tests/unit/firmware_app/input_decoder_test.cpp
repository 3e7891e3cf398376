// InputDecoder: CAN decode with the DBC codec, GNSS fix assembly, cloud reassembly into localizer
// inputs; malformed or truncated input is counted and never disturbs the inputs around it.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "decoded_log.hpp"
#include "share_signing.hpp"

namespace v2xloc::firmware {
namespace {

constexpr std::int64_t kEpoch = 1'700'000'000'000'000'000;

std::vector<std::vector<std::uint8_t>> fragment_cloud(protocol::CloudMessageType type, std::uint32_t sender,
                                                      std::uint32_t seq, std::int64_t stamp_ns,
                                                      const std::vector<float>& xyz,
                                                      const std::vector<std::uint16_t>& times) {
  protocol::CloudFrameInfo info;
  info.type = type;
  info.sender_id = sender;
  info.frame_seq = seq;
  info.timestamp_ns = static_cast<std::uint64_t>(kEpoch + stamp_ns);
  info.pose.position_m[0] = 9.5;
  info.pose.position_m[2] = 5.0;
  info.scale_m = kCloudScaleM;
  protocol::PointCloudFragmenter f;
  EXPECT_EQ(f.begin(info, protocol::CloudPointsView{xyz, {}, times}), protocol::CloudStatus::kOk);
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> buf(1400);
  std::size_t n = 0;
  while (f.next(buf, n) == protocol::CloudStatus::kOk) out.emplace_back(buf.begin(), buf.begin() + static_cast<long>(n));
  return out;
}

std::vector<float> ramp_points(std::size_t n) {
  std::vector<float> xyz;
  for (std::size_t i = 0; i < n; ++i) {
    xyz.push_back(0.01f * static_cast<float>(i));
    xyz.push_back(-0.02f * static_cast<float>(i % 100));
    xyz.push_back(1.5f);
  }
  return xyz;
}

TEST(InputDecoder, VehicleFrameDecodesWithTimeAndBadFramesAreCounted) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  protocol::VehicleMotion m;
  m.wheel_speed_mps = 7.25;
  m.yaw_rate_rps = -0.1234;
  m.speed_valid = m.yaw_rate_valid = true;
  const hal::CanFrame good = protocol::pack(m);

  hal::CanFrame bad_crc = good;
  bad_crc.data[0] ^= 0x01;
  hal::CanFrame short_dlc = good;
  short_dlc.dlc = 5;
  EXPECT_EQ(decoded.can(*dec, bad_crc, kEpoch + 1'000'000), CanInputKind::kRejected);
  EXPECT_EQ(decoded.can(*dec, short_dlc, kEpoch + 1'000'000), CanInputKind::kRejected);
  EXPECT_EQ(decoded.can(*dec, good, kEpoch + 1'500'000'000), CanInputKind::kVehicle);
  hal::CanFrame unknown;
  unknown.id = 0x7AB;
  unknown.dlc = 8;
  EXPECT_EQ(decoded.can(*dec, unknown, kEpoch), CanInputKind::kUnknownId);

  ASSERT_EQ(decoded.vehicle.size(), 1u);
  EXPECT_DOUBLE_EQ(decoded.vehicle[0].t, 1.5);
  EXPECT_NEAR(decoded.vehicle[0].wheel_speed, 7.25, 0.005);
  EXPECT_NEAR(decoded.vehicle[0].yaw_rate, -0.1234, 0.00005);
  EXPECT_EQ(dec->counters().can_rejected, 2u);
  EXPECT_EQ(dec->counters().can_unknown_id, 1u);
  EXPECT_EQ(dec->counters().vehicle_inputs, 1u);

  m.speed_valid = false;
  m.counter = 1;  // the sender's rolling counter advances (a repeat would be dropped)
  EXPECT_EQ(decoded.can(*dec, protocol::pack(m), kEpoch), CanInputKind::kInvalid);
  EXPECT_EQ(dec->counters().vehicle_invalid, 1u);
  EXPECT_EQ(decoded.vehicle.size(), 1u);
}

// Each transmission advances the message's rolling counter, as a sender does (repeats are dropped).
template <typename M>
M next_counter(M& m) {
  const M sent = m;
  m.counter = static_cast<std::uint8_t>((m.counter + 1) % protocol::kCounterModulo);
  return sent;
}

TEST(InputDecoder, GnssFixIsAssembledFromPositionStatusAndTime) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  protocol::GnssPosition pos{48.1374123, 11.5755456};
  protocol::GnssStatus st;
  st.alt_m = 521.25;
  st.h_acc_m = 2.5;
  st.v_acc_m = 4.0;
  st.num_sats = 11;
  st.fix_type = protocol::GnssFixType::kFix3D;
  protocol::GnssTimeDop td;
  td.time_of_week_s = 1234.5;
  td.week = 2290;
  td.hdop = 1.2;

  // Time frame without a status frame: incomplete, counted, nothing forwarded.
  EXPECT_EQ(decoded.can(*dec, protocol::pack(td), kEpoch), CanInputKind::kInvalid);
  EXPECT_EQ(dec->counters().gnss_incomplete, 1u);

  EXPECT_EQ(decoded.can(*dec, protocol::pack(pos), kEpoch + 200'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(next_counter(st)), kEpoch + 200'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(td), kEpoch + 200'000'000), CanInputKind::kGnssFix);
  ASSERT_EQ(decoded.gnss.size(), 1u);
  const GnssInput& g = decoded.gnss[0];
  EXPECT_TRUE(g.valid);
  EXPECT_DOUBLE_EQ(g.t, 0.2);
  EXPECT_NEAR(g.lat_deg, 48.1374123, 1e-7);
  EXPECT_NEAR(g.lon_deg, 11.5755456, 1e-7);
  EXPECT_NEAR(g.alt_m, 521.25, 0.01);
  EXPECT_NEAR(g.h_acc, 2.5, 0.05);
  EXPECT_EQ(g.num_sats, 11);
  EXPECT_NEAR(g.hdop, 1.2, 0.05);
  EXPECT_FALSE(g.velocity_valid) << "no velocity frame in this fix";

  // No position frame (receiver without a fix): forwarded as invalid.
  st.fix_type = protocol::GnssFixType::kNoFix;
  decoded.can(*dec, protocol::pack(next_counter(st)), kEpoch + 400'000'000);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(td), kEpoch + 400'000'000), CanInputKind::kGnssFix);
  ASSERT_EQ(decoded.gnss.size(), 2u);
  EXPECT_FALSE(decoded.gnss[1].valid);

  // A fix with its Doppler velocity (0x133 before the closing time frame).
  st.fix_type = protocol::GnssFixType::kFix3D;
  protocol::GnssVelocity vel;
  vel.vel_east_mps = 7.25;
  vel.vel_north_mps = -3.5;
  vel.speed_acc_mps = 0.14;
  vel.valid = true;
  decoded.can(*dec, protocol::pack(pos), kEpoch + 600'000'000);
  decoded.can(*dec, protocol::pack(next_counter(st)), kEpoch + 600'000'000);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(next_counter(vel)), kEpoch + 600'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(td), kEpoch + 600'000'000), CanInputKind::kGnssFix);
  ASSERT_EQ(decoded.gnss.size(), 3u);
  EXPECT_TRUE(decoded.gnss[2].velocity_valid);
  EXPECT_NEAR(decoded.gnss[2].vel_east, 7.25, 0.005);
  EXPECT_NEAR(decoded.gnss[2].vel_north, -3.5, 0.005);
  EXPECT_NEAR(decoded.gnss[2].speed_acc, 0.14, 0.01);
  // The velocity belongs to that fix only: the next fix without 0x133 has none.
  decoded.can(*dec, protocol::pack(pos), kEpoch + 800'000'000);
  decoded.can(*dec, protocol::pack(next_counter(st)), kEpoch + 800'000'000);
  decoded.can(*dec, protocol::pack(td), kEpoch + 800'000'000);
  ASSERT_EQ(decoded.gnss.size(), 4u);
  EXPECT_FALSE(decoded.gnss[3].velocity_valid);
  // A corrupted velocity frame is rejected and counted; the fix still arrives without it.
  hal::CanFrame bad = protocol::pack(next_counter(vel));
  bad.data[0] ^= 0x01;
  const auto rejected_before = dec->counters().can_rejected;
  decoded.can(*dec, protocol::pack(pos), kEpoch + 1'000'000'000);
  decoded.can(*dec, protocol::pack(next_counter(st)), kEpoch + 1'000'000'000);
  EXPECT_EQ(decoded.can(*dec, bad, kEpoch + 1'000'000'000), CanInputKind::kRejected);
  decoded.can(*dec, protocol::pack(td), kEpoch + 1'000'000'000);
  EXPECT_EQ(dec->counters().can_rejected, rejected_before + 1);
  ASSERT_EQ(decoded.gnss.size(), 5u);
  EXPECT_TRUE(decoded.gnss[4].valid);
  EXPECT_FALSE(decoded.gnss[4].velocity_valid);
}

TEST(InputDecoder, CloudsSurviveTruncatedCorruptAndDuplicateFragments) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
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
  EXPECT_FALSE(dec->on_datagram(truncated, 0));
  EXPECT_FALSE(dec->on_datagram(flipped, 0));
  EXPECT_FALSE(dec->on_datagram(frags[0], 0));
  EXPECT_FALSE(dec->on_datagram(frags[0], 0));  // duplicate
  bool completed = false;
  for (std::size_t k = frags.size() - 1; k >= 1; --k) {
    completed = dec->on_datagram(frags[k], 0);
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
  EXPECT_FALSE(decoded.ego_gnss_used[0]);
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
  EXPECT_EQ(dec->counters().map_clouds, 2u);
  EXPECT_EQ(dec->verifier().counters().accepted, 2u);

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
  EXPECT_EQ(dec->verifier().counters().replay, 1u);
  EXPECT_EQ(dec->verifier().counters().missing_signature, 1u);
  EXPECT_EQ(dec->counters().shares_untrusted, 2u);
}

TEST(InputDecoder, EgoScanFromAnotherSenderIsRejectedAndCounted) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  const auto frags = fragment_cloud(protocol::CloudMessageType::kEgoScan, 5, 0, 0, ramp_points(10), {});
  ASSERT_EQ(frags.size(), 1u);
  ASSERT_TRUE(dec->on_datagram(frags[0], 0));
  EXPECT_EQ(decoded.cloud(*dec), CloudKind::kRejected);
  EXPECT_EQ(dec->counters().clouds_rejected, 1u);
  EXPECT_TRUE(decoded.ego.empty());
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
