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

// An ego scan: a period boundary (the first one opens the first period; before it, a share's
// signature is checked as it completes).
void ego_scan(InputDecoder& dec, std::uint32_t seq, std::int64_t now_ns) {
  const auto ego = fragment_cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, seq, now_ns, ramp_points(50), {});
  for (const auto& f : ego) dec.on_datagram(f, now_ns);
  ASSERT_EQ(dec.decode_completed().kind, CloudKind::kEgoScan);
}

// A map share signed by `sender` and all its fragments, completed and queued.
void queue_signed_share(InputDecoder& dec, std::uint32_t sender, std::int64_t now_ns, const std::vector<float>& xyz) {
  const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, now_ns, xyz, {});
  dec.on_datagram(test::sign_share(frags, sender, kEpoch + now_ns), now_ns);
  bool done = false;
  for (const auto& f : frags) done = dec.on_datagram(f, now_ns);
  ASSERT_TRUE(done);
  ASSERT_EQ(dec.decode_completed().kind, CloudKind::kMapQueued) << sender;
}

// The source ids of the shares this period releases, each verified and fused.
std::vector<std::uint32_t> fused_sources(InputDecoder& dec, const MapShareWanted& wanted) {
  std::vector<std::uint32_t> fused;
  for (std::size_t guard = 0; guard < 10; ++guard) {
    const DecodedCloud share = dec.next_verified_share(&wanted);
    if (share.kind == CloudKind::kNone) break;
    EXPECT_EQ(share.kind, CloudKind::kMapCloud);
    fused.push_back(share.map.source_id);
  }
  return fused;
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

// One GNSS sender as layout 2 steps its counters: 0x130 +1 per frame, the other ids +1 per fix.
struct GnssSender {
  std::uint8_t position_counter = 0;
  std::uint8_t fix_counter = 0;
  protocol::GnssStatus status;
  protocol::GnssDop dop{1.2, 1.9, 0};
  protocol::GnssTime time{1234.5, 2290, 0};

  GnssSender() {
    status.alt_m = 521.25;
    status.h_acc_m = 2.5;
    status.v_acc_m = 4.0;
    status.num_sats = 11;
    status.fix_type = protocol::GnssFixType::kFix3D;
  }
  hal::CanFrame half(protocol::GnssPositionHalf h, double deg) {
    const hal::CanFrame f = protocol::pack(protocol::GnssPosition{h, deg, position_counter});
    position_counter = static_cast<std::uint8_t>((position_counter + 1) % protocol::kCounterModulo);
    return f;
  }
  hal::CanFrame lat(double deg) { return half(protocol::GnssPositionHalf::kLatitude, deg); }
  hal::CanFrame lon(double deg) { return half(protocol::GnssPositionHalf::kLongitude, deg); }
  // The status, DOP and time frames of the current fix (the time frame closes it); then the next fix.
  std::vector<hal::CanFrame> rest() {
    status.counter = dop.counter = time.counter = fix_counter;
    fix_counter = static_cast<std::uint8_t>((fix_counter + 1) % protocol::kCounterModulo);
    return {protocol::pack(status), protocol::pack(dop), protocol::pack(time)};
  }
};

TEST(InputDecoder, GnssFixIsAssembledFromPositionStatusAndTime) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  GnssSender gnss;

  // Time frame without a status frame: incomplete, counted, nothing forwarded.
  EXPECT_EQ(decoded.can(*dec, protocol::pack(gnss.time), kEpoch), CanInputKind::kInvalid);
  EXPECT_EQ(dec->counters().gnss_incomplete, 1u);
  gnss.fix_counter = 1;

  EXPECT_EQ(decoded.can(*dec, gnss.lat(48.1374123), kEpoch + 200'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, gnss.lon(11.5755456), kEpoch + 200'000'000), CanInputKind::kGnssPart);
  const auto rest = gnss.rest();
  EXPECT_EQ(decoded.can(*dec, rest[0], kEpoch + 200'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, rest[1], kEpoch + 200'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, rest[2], kEpoch + 200'000'000), CanInputKind::kGnssFix);
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
  EXPECT_EQ(dec->counters().gnss_position_dropped, 0u);

  // No position frames (receiver without a fix) and no DOP: forwarded as invalid, hdop unknown.
  gnss.status.fix_type = protocol::GnssFixType::kNoFix;
  const auto no_fix = gnss.rest();
  decoded.can(*dec, no_fix[0], kEpoch + 400'000'000);
  EXPECT_EQ(decoded.can(*dec, no_fix[2], kEpoch + 400'000'000), CanInputKind::kGnssFix);
  ASSERT_EQ(decoded.gnss.size(), 2u);
  EXPECT_FALSE(decoded.gnss[1].valid);
  EXPECT_EQ(decoded.gnss[1].hdop, GnssInput{}.hdop);

  // A fix with its Doppler velocity (0x133 before the closing time frame).
  gnss.status.fix_type = protocol::GnssFixType::kFix3D;
  protocol::GnssVelocity vel;
  vel.vel_east_mps = 7.25;
  vel.vel_north_mps = -3.5;
  vel.speed_acc_mps = 0.14;
  vel.valid = true;
  decoded.can(*dec, gnss.lat(48.1), kEpoch + 600'000'000);
  decoded.can(*dec, gnss.lon(11.5), kEpoch + 600'000'000);
  const auto with_vel = gnss.rest();
  decoded.can(*dec, with_vel[0], kEpoch + 600'000'000);
  EXPECT_EQ(decoded.can(*dec, protocol::pack(next_counter(vel)), kEpoch + 600'000'000), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, with_vel[2], kEpoch + 600'000'000), CanInputKind::kGnssFix);
  ASSERT_EQ(decoded.gnss.size(), 3u);
  EXPECT_TRUE(decoded.gnss[2].velocity_valid);
  EXPECT_NEAR(decoded.gnss[2].vel_east, 7.25, 0.005);
  EXPECT_NEAR(decoded.gnss[2].vel_north, -3.5, 0.005);
  EXPECT_NEAR(decoded.gnss[2].speed_acc, 0.14, 0.01);
  // The velocity belongs to that fix only: the next fix without 0x133 has none.
  decoded.can(*dec, gnss.lat(48.1), kEpoch + 800'000'000);
  decoded.can(*dec, gnss.lon(11.5), kEpoch + 800'000'000);
  for (const hal::CanFrame& f : gnss.rest()) decoded.can(*dec, f, kEpoch + 800'000'000);
  ASSERT_EQ(decoded.gnss.size(), 4u);
  EXPECT_FALSE(decoded.gnss[3].velocity_valid);
  // A corrupted velocity frame is rejected and counted; the fix still arrives without it.
  hal::CanFrame bad = protocol::pack(next_counter(vel));
  bad.data[0] ^= 0x01;
  const auto rejected_before = dec->counters().can_rejected;
  decoded.can(*dec, gnss.lat(48.1), kEpoch + 1'000'000'000);
  decoded.can(*dec, gnss.lon(11.5), kEpoch + 1'000'000'000);
  const auto last = gnss.rest();
  decoded.can(*dec, last[0], kEpoch + 1'000'000'000);
  EXPECT_EQ(decoded.can(*dec, bad, kEpoch + 1'000'000'000), CanInputKind::kRejected);
  decoded.can(*dec, last[2], kEpoch + 1'000'000'000);
  EXPECT_EQ(dec->counters().can_rejected, rejected_before + 1);
  ASSERT_EQ(decoded.gnss.size(), 5u);
  EXPECT_TRUE(decoded.gnss[4].valid);
  EXPECT_FALSE(decoded.gnss[4].velocity_valid);
}

// Layout 2 gave the GNSS position and time frames a rolling counter and a CRC: a repeated frame
// (replayed or stuck) is refused and counted as the other frames' repeats are; a corrupt one too.
TEST(InputDecoder, RepeatedOrCorruptGnssFramesAreRefused) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  GnssSender gnss;
  const hal::CanFrame lat = gnss.lat(48.1), lon = gnss.lon(11.5);
  const auto rest = gnss.rest();
  EXPECT_EQ(decoded.can(*dec, lat, kEpoch), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, lat, kEpoch), CanInputKind::kRejected) << "a repeated latitude";
  EXPECT_EQ(decoded.can(*dec, lon, kEpoch), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, rest[0], kEpoch), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, rest[1], kEpoch), CanInputKind::kGnssPart);
  EXPECT_EQ(decoded.can(*dec, rest[1], kEpoch), CanInputKind::kRejected) << "a repeated DOP frame";
  EXPECT_EQ(decoded.can(*dec, rest[2], kEpoch), CanInputKind::kGnssFix);
  EXPECT_EQ(decoded.can(*dec, rest[2], kEpoch), CanInputKind::kRejected) << "a replayed time frame closes nothing";
  EXPECT_EQ(dec->counters().can_repeated, 3u);
  ASSERT_EQ(decoded.gnss.size(), 1u);
  EXPECT_TRUE(decoded.gnss[0].valid);

  // One flipped bit anywhere in a latitude, longitude or time frame: a CRC failure, counted.
  const hal::CanFrame frames[] = {gnss.lat(48.2), gnss.lon(11.6), gnss.rest()[2]};
  const auto rejected = dec->counters().can_rejected;
  for (const hal::CanFrame& good : frames) {
    for (int bit = 0; bit < 64; bit += 7) {
      hal::CanFrame f = good;
      f.data[bit / 8] = static_cast<std::uint8_t>(f.data[bit / 8] ^ (1u << (bit % 8)));
      EXPECT_EQ(decoded.can(*dec, f, kEpoch), CanInputKind::kRejected) << std::hex << f.id << " bit " << std::dec << bit;
    }
  }
  EXPECT_EQ(dec->counters().can_rejected, rejected + 30u);
  EXPECT_EQ(decoded.gnss.size(), 1u);
  EXPECT_EQ(dec->counters().can_repeated, 3u) << "CRC failures are not counted as repeats";
}

// A gap in a GNSS counter is handled as on the other frames: the frame is used, the gap counted.
TEST(InputDecoder, GnssCounterGapIsAcceptedAndCounted) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  GnssSender gnss;
  for (const hal::CanFrame& f : {gnss.lat(48.1), gnss.lon(11.5)}) decoded.can(*dec, f, kEpoch);
  for (const hal::CanFrame& f : gnss.rest()) decoded.can(*dec, f, kEpoch);
  // Two whole fixes lost on the bus: every GNSS counter jumps.
  for (int k = 0; k < 2; ++k) {
    gnss.lat(0.0);
    gnss.lon(0.0);
    gnss.rest();
  }
  for (const hal::CanFrame& f : {gnss.lat(48.2), gnss.lon(11.6)}) decoded.can(*dec, f, kEpoch + 600'000'000);
  for (const hal::CanFrame& f : gnss.rest()) EXPECT_NE(decoded.can(*dec, f, kEpoch + 600'000'000), CanInputKind::kRejected);
  ASSERT_EQ(decoded.gnss.size(), 2u);
  EXPECT_TRUE(decoded.gnss[1].valid);
  EXPECT_NEAR(decoded.gnss[1].lat_deg, 48.2, 1e-7);
  EXPECT_NEAR(decoded.gnss[1].lon_deg, 11.6, 1e-7);
  // 0x130 skipped 4 frames; 0x131, 0x134 and 0x132 skipped 2 each.
  EXPECT_EQ(dec->counters().can_counter_gaps, 4u + 3u * 2u);
  EXPECT_EQ(dec->counters().can_repeated, 0u);
}

// A position is used only when both halves of the same fix arrived intact and in order: a lone
// latitude or longitude, or halves whose counters are not consecutive, never form a fix.
TEST(InputDecoder, LoneOrMismatchedPositionHalvesNeverFormAFix) {
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  test::DecodedLog decoded;
  GnssSender gnss;
  const auto close_fix = [&](std::int64_t t) {
    for (const hal::CanFrame& f : gnss.rest()) decoded.can(*dec, f, t);
  };
  // 1. A complete fix.
  decoded.can(*dec, gnss.lat(48.1), kEpoch);
  decoded.can(*dec, gnss.lon(11.5), kEpoch);
  close_fix(kEpoch);
  // 2. Latitude only (its longitude lost): no position.
  decoded.can(*dec, gnss.lat(48.2), kEpoch + 200'000'000);
  gnss.lon(0.0);
  close_fix(kEpoch + 200'000'000);
  // 3. Longitude only (its latitude corrupted): no position, never the previous fix's latitude.
  hal::CanFrame bad_lat = gnss.lat(48.3);
  bad_lat.data[2] ^= 0x08;
  EXPECT_EQ(decoded.can(*dec, bad_lat, kEpoch + 400'000'000), CanInputKind::kRejected);
  EXPECT_EQ(decoded.can(*dec, gnss.lon(11.7), kEpoch + 400'000'000), CanInputKind::kInvalid);
  close_fix(kEpoch + 400'000'000);
  // 4. An old latitude (captured from fix 2) injected before this fix's longitude: its counter
  // is not the one before the longitude's, so neither pairs.
  const hal::CanFrame new_lat = gnss.lat(48.4), new_lon = gnss.lon(11.8);
  hal::CanFrame old_lat = protocol::pack(protocol::GnssPosition{protocol::GnssPositionHalf::kLatitude, 48.2, 2});
  decoded.can(*dec, new_lat, kEpoch + 600'000'000);
  decoded.can(*dec, old_lat, kEpoch + 600'000'000);
  EXPECT_EQ(decoded.can(*dec, new_lon, kEpoch + 600'000'000), CanInputKind::kInvalid);
  close_fix(kEpoch + 600'000'000);
  // 5. Both halves again: a fix with this fix's values.
  decoded.can(*dec, gnss.lat(48.5), kEpoch + 800'000'000);
  decoded.can(*dec, gnss.lon(11.9), kEpoch + 800'000'000);
  close_fix(kEpoch + 800'000'000);

  ASSERT_EQ(decoded.gnss.size(), 5u);
  EXPECT_TRUE(decoded.gnss[0].valid);
  EXPECT_FALSE(decoded.gnss[1].valid);
  EXPECT_FALSE(decoded.gnss[2].valid);
  EXPECT_FALSE(decoded.gnss[3].valid);
  EXPECT_TRUE(decoded.gnss[4].valid);
  EXPECT_NEAR(decoded.gnss[4].lat_deg, 48.5, 1e-7);
  EXPECT_NEAR(decoded.gnss[4].lon_deg, 11.9, 1e-7);
  // Dropped halves: fix 2's latitude, fix 3's longitude, fix 4's new latitude (replaced), the old
  // latitude and the longitude (counter mismatch).
  EXPECT_EQ(dec->counters().gnss_position_dropped, 5u);
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
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 0, 400'000'000));
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
  EXPECT_EQ(dec->counters().shares_queued, kSources);
  EXPECT_EQ(dec->counters().shares_queue_dropped, 2u);  // sources 0 and 1, the oldest
  EXPECT_EQ(dec->shares_waiting(), kShareVerifyQueueCapacity);
  EXPECT_EQ(dec->verifier().counters().accepted, 0u) << "no ECDSA before the period boundary";

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
  EXPECT_EQ(dec->shares_waiting(), kShareVerifyQueueCapacity - 2);
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
  EXPECT_EQ(dec->verifier().counters().bad_signature, 1u);
  EXPECT_EQ(dec->verifier().counters().accepted, kShareVerifyQueueCapacity - 1);
  EXPECT_EQ(dec->counters().signature_verifications, kShareVerifyQueueCapacity);
  EXPECT_EQ(dec->counters().shares_untrusted, 1u);
}

// Shares the map would not fuse (the localizer paces each source, reference_map.hpp) are skipped
// before their signature check: no ECDSA spent, counted, and the period's budget goes to the next.
TEST(InputDecoder, SharesTheMapDoesNotWantCostNoSignatureCheck) {
  struct EverySecondSender final : MapShareWanted {
    bool wants(std::uint32_t source_id, double t) const override {
      EXPECT_DOUBLE_EQ(t, 0.5);
      return (source_id - kInfraSenderBase) % 2 == 0;
    }
  };
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  trust::TrustList list;
  constexpr std::uint32_t kSources = 4;
  for (std::uint32_t k = 0; k < kSources; ++k) test::add_signer(list, kInfraSenderBase + k, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  const std::vector<float> xyz = ramp_points(100);
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 0, 400'000'000));
  for (std::uint32_t k = 0; k < kSources; ++k) {
    ASSERT_NO_FATAL_FAILURE(queue_signed_share(*dec, kInfraSenderBase + k, 500'000'000, xyz));
  }
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 1, 600'000'000));
  const EverySecondSender wanted;
  EXPECT_EQ(fused_sources(*dec, wanted), (std::vector<std::uint32_t>{kInfraSenderBase, kInfraSenderBase + 2}));
  EXPECT_EQ(dec->counters().shares_paced, 1u);
  EXPECT_EQ(dec->counters().signature_verifications, 2u);
  EXPECT_EQ(dec->shares_waiting(), 1u) << "the budget is spent: the last share waits for the next period";
}

// With a share filter, a share the map would not fuse is decided on its first fragment: none of its
// fragments is hashed, it completes as kMapPaced (counted) and costs no signature check; a wanted
// share is hashed, queued and verified. The trust work (hashing, ECDSA) is reported once per period.
TEST(InputDecoder, UnwantedSharesAreNotHashedAndTrustWorkIsReported) {
  struct OnlyEvenSenders final : MapShareWanted {
    bool wants(std::uint32_t source_id, double t) const override {
      EXPECT_DOUBLE_EQ(t, 0.5);  // the header's time, as the queue would judge it
      ++asked;
      return (source_id - kInfraSenderBase) % 2 == 0;
    }
    mutable int asked = 0;
  };
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  const OnlyEvenSenders wanted;
  dec->set_share_filter(&wanted);
  trust::TrustList list;
  for (std::uint32_t k = 0; k < 2; ++k) test::add_signer(list, kInfraSenderBase + k, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  const std::vector<float> xyz = ramp_points(400);
  std::size_t hashed_bytes = 0;
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 0, 400'000'000));
  for (std::uint32_t k = 0; k < 2; ++k) {
    const std::uint32_t sender = kInfraSenderBase + k;
    const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, 0, 500'000'000, xyz, {});
    ASSERT_GT(frags.size(), 1u);
    dec->on_datagram(test::sign_share(frags, sender, kEpoch + 500'000'000), 500'000'000);
    bool done = false;
    for (const auto& f : frags) {
      done = dec->on_datagram(f, 500'000'000);
      if (k == 0) hashed_bytes += f.size() - protocol::pointcloud_wire::kHeaderBytes - protocol::pointcloud_wire::kTrailerBytes;
    }
    ASSERT_TRUE(done);
    EXPECT_EQ(dec->decode_completed().kind, k == 0 ? CloudKind::kMapQueued : CloudKind::kMapPaced) << k;
  }
  EXPECT_EQ(wanted.asked, 2) << "asked once per share, on its first fragment";
  EXPECT_EQ(dec->counters().shares_paced_on_arrival, 1u);
  EXPECT_EQ(dec->counters().shares_queued, 1u);
  const double hashing = kShareHashInstructionsPerByte * static_cast<double>(hashed_bytes);
  EXPECT_DOUBLE_EQ(dec->take_trust_work(), hashing) << "only the wanted share's fragments were hashed";
  EXPECT_DOUBLE_EQ(dec->take_trust_work(), 0.0) << "reported once";

  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 1, 600'000'000));
  const DecodedCloud share = dec->next_verified_share(&wanted);
  ASSERT_EQ(share.kind, CloudKind::kMapCloud);
  EXPECT_EQ(share.map.source_id, kInfraSenderBase);
  EXPECT_EQ(dec->next_verified_share(&wanted).kind, CloudKind::kNone);
  EXPECT_EQ(dec->counters().signature_verifications, 1u);
  EXPECT_DOUBLE_EQ(dec->take_trust_work(), kShareVerifyInstructions);
}

// An infrastructure share the map would refuse as off its surveyed background is refused before
// its ECDSA: counted, and its place in the period goes to the next share. Agents are not asked.
TEST(InputDecoder, SharesOffTheirBackgroundCostNoSignatureCheck) {
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
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  trust::TrustList list;
  test::add_signer(list, kInfraSenderBase, trust::SignerRole::kInfrastructure);
  test::add_signer(list, kInfraSenderBase + 1, trust::SignerRole::kInfrastructure);
  test::add_signer(list, kAgentSenderBase, trust::SignerRole::kAgent);
  test::add_signer(list, kInfraSenderBase + 2, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  const std::vector<float> xyz = ramp_points(100);
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 0, 400'000'000));
  for (const std::uint32_t sender : {kInfraSenderBase + 1, kAgentSenderBase, kInfraSenderBase, kInfraSenderBase + 2}) {
    ASSERT_NO_FATAL_FAILURE(queue_signed_share(*dec, sender, 500'000'000, xyz));
  }
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 1, 600'000'000));
  const SecondUnitIsOff wanted;
  static_assert(kMaxSignatureVerificationsPerPeriod == 2);
  EXPECT_EQ(fused_sources(*dec, wanted), (std::vector<std::uint32_t>{kAgentSenderBase, kInfraSenderBase}));
  EXPECT_EQ(wanted.asked, (std::vector<std::uint32_t>{kInfraSenderBase + 1, kInfraSenderBase}));
  EXPECT_EQ(dec->counters().shares_off_background, 1u);
  EXPECT_EQ(dec->counters().signature_verifications, 2u);
  EXPECT_EQ(dec->shares_waiting(), 1u) << "the budget is spent: the last share waits for the next period";
}

// Until the localizer has a map, a share's ECDSA runs as it completes, at most
// kMaxSignatureVerificationsPerPeriod a period (before the first ego scan: every share); the period that fuses it
// releases it on the same schedule as ever without verifying it again (a share whose signature
// failed is still refused then), and charges it to its budget as ever.
TEST(InputDecoder, SignaturesAreCheckedOnArrivalUntilTheFirstMap) {
  struct MapPending final : MapShareWanted {
    bool wants(std::uint32_t, double) const override { return true; }
    bool awaiting_first_map() const override { return pending; }
    bool pending = true;
  };
  static_assert(kMaxSignatureVerificationsPerPeriod == 2);
  auto dec = std::make_unique<InputDecoder>(kEpoch);
  MapPending map_pending;
  dec->set_share_filter(&map_pending);
  trust::TrustList list;
  constexpr std::uint32_t kSources = 5;
  for (std::uint32_t k = 0; k < kSources; ++k) test::add_signer(list, kInfraSenderBase + k, trust::SignerRole::kInfrastructure);
  dec->provision_trust(list);
  const std::vector<float> xyz = ramp_points(100);
  std::vector<float> tampered = xyz;
  tampered[3 * 99] += 0.01f;
  const auto send = [&](std::uint32_t k, std::int64_t now_ns, bool tamper, std::uint32_t seq = 0) {
    const std::uint32_t sender = kInfraSenderBase + k;
    const auto frags = fragment_cloud(protocol::CloudMessageType::kMapShare, sender, seq, now_ns, xyz, {});
    dec->on_datagram(test::sign_share(frags, sender, kEpoch + now_ns), now_ns);
    const auto sent = tamper ? fragment_cloud(protocol::CloudMessageType::kMapShare, sender, seq, now_ns, tampered, {}) : frags;
    bool done = false;
    for (const auto& f : sent) done = dec->on_datagram(f, now_ns);
    ASSERT_TRUE(done);
    ASSERT_EQ(dec->decode_completed().kind, CloudKind::kMapQueued) << k;
  };
  const auto release_all = [&] {
    std::vector<CloudKind> released;
    for (std::size_t guard = 0; guard < 10; ++guard) {
      const DecodedCloud share = dec->next_verified_share(&map_pending);
      if (share.kind == CloudKind::kNone) break;
      released.push_back(share.kind);
    }
    return released;
  };
  for (std::uint32_t k = 0; k < 3; ++k) send(k, 500'000'000, k == 0);
  EXPECT_EQ(dec->counters().signatures_checked_on_arrival, 3u) << "before the first scan: all";
  EXPECT_EQ(dec->counters().signature_verifications, 3u);
  EXPECT_EQ(dec->verifier().counters().accepted, 0u) << "accepted only at a period boundary";

  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 0, 600'000'000));
  EXPECT_GT(dec->take_trust_work(), 0.0) << "the shares' hashing";
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kRejected, CloudKind::kMapCloud}));
  EXPECT_EQ(dec->verifier().counters().bad_signature, 1u);
  EXPECT_EQ(dec->counters().signature_verifications, 3u) << "none verified twice";
  EXPECT_DOUBLE_EQ(dec->take_trust_work(), 2 * kShareVerifyInstructions) << "charged where released, as ever";

  send(3, 650'000'000, false);  // still no map: checked on arrival (two a period)
  send(4, 650'000'000, false);
  EXPECT_EQ(dec->counters().signatures_checked_on_arrival, 5u);
  map_pending.pending = false;
  send(0, 660'000'000, false, 1);  // the map exists: verified at its release, as ever
  EXPECT_EQ(dec->counters().signatures_checked_on_arrival, 5u);
  EXPECT_EQ(dec->counters().signature_verifications, 5u);
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 1, 700'000'000));
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kMapCloud, CloudKind::kMapCloud}));
  EXPECT_EQ(dec->shares_waiting(), 2u);
  EXPECT_EQ(dec->counters().signature_verifications, 5u) << "all released ones were checked on arrival";
  ASSERT_NO_FATAL_FAILURE(ego_scan(*dec, 2, 800'000'000));
  EXPECT_EQ(release_all(), (std::vector<CloudKind>{CloudKind::kMapCloud, CloudKind::kMapCloud}));
  EXPECT_EQ(dec->counters().signature_verifications, 6u) << "the last one, sent with a map, verified at release";
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
