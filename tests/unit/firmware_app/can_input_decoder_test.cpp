// CanInputDecoder: CAN frames decoded with the DBC codec and checked by their rolling counters, the
// GNSS fix assembled from its frames (GnssFixAssembler); malformed, repeated or unpaired frames are
// counted and never disturb the inputs around them.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "firmware/wire/can_input_decoder.hpp"
#include "decoded_log.hpp"
#include "test_clouds.hpp"

namespace v2xloc::firmware {
namespace {

using test::kEpoch;

TEST(CanInputDecoder, VehicleFrameDecodesWithTimeAndBadFramesAreCounted) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
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

TEST(CanInputDecoder, GnssFixIsAssembledFromPositionStatusAndTime) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
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
TEST(CanInputDecoder, RepeatedOrCorruptGnssFramesAreRefused) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
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
TEST(CanInputDecoder, GnssCounterGapIsAcceptedAndCounted) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
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
TEST(CanInputDecoder, LoneOrMismatchedPositionHalvesNeverFormAFix) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
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

// The GnssUsed pose flag: a decoded fix is reported once, to the next ego scan; an incomplete fix
// (no status frame) or a position half alone is not a fix.
TEST(CanInputDecoder, GnssFixSeenIsTakenOnce) {
  auto dec = std::make_unique<CanInputDecoder>(kEpoch);
  test::DecodedLog decoded;
  GnssSender gnss;
  EXPECT_FALSE(dec->take_gnss_fix_seen());
  EXPECT_EQ(decoded.can(*dec, gnss.lat(48.1), kEpoch), CanInputKind::kGnssPart);
  EXPECT_FALSE(dec->take_gnss_fix_seen()) << "a position half is not a fix";
  decoded.can(*dec, gnss.lon(11.5), kEpoch);
  for (const hal::CanFrame& f : gnss.rest()) decoded.can(*dec, f, kEpoch);
  ASSERT_EQ(decoded.gnss.size(), 1u);
  EXPECT_TRUE(dec->take_gnss_fix_seen());
  EXPECT_FALSE(dec->take_gnss_fix_seen()) << "taken once";
  const hal::CanFrame time_only = gnss.rest()[2];
  EXPECT_EQ(decoded.can(*dec, time_only, kEpoch + 200'000'000), CanInputKind::kInvalid);
  EXPECT_FALSE(dec->take_gnss_fix_seen()) << "a fix without status is not forwarded";
  EXPECT_EQ(dec->counters().gnss_incomplete, 1u);
  EXPECT_DOUBLE_EQ(dec->last_gnss_time().time_of_week_s, 1234.5) << "the time frame is kept for the PPS";
}

// Every part belongs to the fix its time frame closes: nothing carries over to the next fix.
TEST(GnssFixAssembler, PartsBelongToTheFixTheyArriveIn) {
  GnssFixAssembler fix;
  protocol::GnssStatus status;
  status.fix_type = protocol::GnssFixType::kFix2D;
  status.alt_m = 12.5;
  status.num_sats = 7;
  protocol::GnssVelocity velocity;
  velocity.vel_east_mps = 1.5;
  velocity.valid = true;
  fix.set_status(status);
  fix.set_dop(protocol::GnssDop{0.8, 1.1, 0});
  fix.set_velocity(velocity);
  EXPECT_EQ(fix.add_position(protocol::GnssPosition{protocol::GnssPositionHalf::kLatitude, 48.25, 4}),
            protocol::GnssPositionPairer::Result::kWaiting);
  EXPECT_EQ(fix.add_position(protocol::GnssPosition{protocol::GnssPositionHalf::kLongitude, 11.75, 5}),
            protocol::GnssPositionPairer::Result::kPaired);
  GnssInput g;
  ASSERT_TRUE(fix.close(3.25, g));
  EXPECT_TRUE(g.valid);
  EXPECT_DOUBLE_EQ(g.t, 3.25);
  EXPECT_DOUBLE_EQ(g.lat_deg, 48.25);
  EXPECT_DOUBLE_EQ(g.lon_deg, 11.75);
  EXPECT_DOUBLE_EQ(g.alt_m, 12.5);
  EXPECT_EQ(g.num_sats, 7);
  EXPECT_DOUBLE_EQ(g.hdop, 0.8);
  EXPECT_TRUE(g.velocity_valid);
  EXPECT_DOUBLE_EQ(g.vel_east, 1.5);

  GnssInput untouched;
  untouched.t = -1.0;
  EXPECT_FALSE(fix.close(3.5, untouched)) << "the status went with the previous fix";
  EXPECT_DOUBLE_EQ(untouched.t, -1.0);

  // Status only, and a latitude whose longitude never came: no position, no DOP, no velocity.
  fix.set_status(status);
  fix.add_position(protocol::GnssPosition{protocol::GnssPositionHalf::kLatitude, 48.5, 6});
  GnssInput bare;
  ASSERT_TRUE(fix.close(3.75, bare));
  EXPECT_FALSE(bare.valid);
  EXPECT_EQ(bare.hdop, GnssInput{}.hdop);
  EXPECT_FALSE(bare.velocity_valid);
  EXPECT_EQ(fix.positions_dropped(), 1u) << "the waiting latitude is dropped when the fix closes";
}

}  // namespace
}  // namespace v2xloc::firmware
