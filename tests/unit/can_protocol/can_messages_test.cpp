#include "firmware/protocol/can_messages.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include "message_bindings.hpp"

namespace v2xloc::protocol {
namespace {

TEST(CanMessages, Crc8J1850CheckValue) {
  const char* check = "123456789";
  EXPECT_EQ(crc8_j1850(reinterpret_cast<const std::uint8_t*>(check), 9), 0x4B);
}

TEST(CanMessages, RoundTripEveryMessage) {
  VehicleMotion vm{-12.34, 0.4321, true, false, 7};
  VehicleMotion vm2;
  ASSERT_EQ(unpack(pack(vm), vm2), DecodeStatus::kOk);
  EXPECT_NEAR(vm2.wheel_speed_mps, vm.wheel_speed_mps, 0.005);
  EXPECT_NEAR(vm2.yaw_rate_rps, vm.yaw_rate_rps, 5e-5);
  EXPECT_TRUE(vm2.speed_valid);
  EXPECT_FALSE(vm2.yaw_rate_valid);
  EXPECT_EQ(vm2.counter, 7);

  GnssPosition lat{GnssPositionHalf::kLatitude, 48.1371549, 6}, lon{GnssPositionHalf::kLongitude, -179.9999999, 7}, gp2;
  ASSERT_EQ(unpack(pack(lat), gp2), DecodeStatus::kOk);
  EXPECT_EQ(gp2.half, GnssPositionHalf::kLatitude);
  EXPECT_NEAR(gp2.deg, lat.deg, 5.1e-8);
  EXPECT_EQ(gp2.counter, 6);
  ASSERT_EQ(unpack(pack(lon), gp2), DecodeStatus::kOk);
  EXPECT_EQ(gp2.half, GnssPositionHalf::kLongitude);
  EXPECT_NEAR(gp2.deg, lon.deg, 5.1e-8);  // 1e-7 deg over the whole longitude range
  EXPECT_EQ(gp2.counter, 7);

  GnssStatus gs{519.37, 4.75, 8.2, 11, GnssFixType::kFix3D, 15}, gs2;
  ASSERT_EQ(unpack(pack(gs), gs2), DecodeStatus::kOk);
  EXPECT_NEAR(gs2.alt_m, gs.alt_m, 0.005);
  EXPECT_NEAR(gs2.h_acc_m, gs.h_acc_m, 0.025);
  EXPECT_NEAR(gs2.v_acc_m, gs.v_acc_m, 0.025);
  EXPECT_EQ(gs2.num_sats, 11);
  EXPECT_EQ(gs2.fix_type, GnssFixType::kFix3D);
  EXPECT_EQ(gs2.counter, 15);

  GnssTime td{345600.125, 2390, 12}, td2;
  ASSERT_EQ(unpack(pack(td), td2), DecodeStatus::kOk);
  EXPECT_NEAR(td2.time_of_week_s, td.time_of_week_s, 5e-4);
  EXPECT_EQ(td2.week, 2390);
  EXPECT_EQ(td2.counter, 12);

  GnssDop dop{1.3, 2.1, 5}, dop2;
  ASSERT_EQ(unpack(pack(dop), dop2), DecodeStatus::kOk);
  EXPECT_NEAR(dop2.hdop, 1.3, 0.05);
  EXPECT_NEAR(dop2.pdop, 2.1, 0.05);
  EXPECT_EQ(dop2.counter, 5);

  PosePosition pp{-123.4567, 4567.891, {true, false, true, false}, 3}, pp2;
  ASSERT_EQ(unpack(pack(pp), pp2), DecodeStatus::kOk);
  EXPECT_NEAR(pp2.x_m, pp.x_m, 5e-4);
  EXPECT_NEAR(pp2.y_m, pp.y_m, 5e-4);
  EXPECT_TRUE(pp2.flags.pose_valid);
  EXPECT_FALSE(pp2.flags.registration_valid);
  EXPECT_TRUE(pp2.flags.gnss_used);
  EXPECT_FALSE(pp2.flags.degraded);
  EXPECT_EQ(pp2.counter, 3);

  PoseAttitude pa{1.23, -2.5, 65535, {false, true, false, true}, 9}, pa2;
  ASSERT_EQ(unpack(pack(pa), pa2), DecodeStatus::kOk);
  EXPECT_NEAR(pa2.z_m, 1.23, 0.005);
  EXPECT_NEAR(pa2.yaw_rad, -2.5, 5e-5);
  EXPECT_EQ(pa2.frame_counter, 65535);
  EXPECT_TRUE(pa2.flags.registration_valid && pa2.flags.degraded);

  PoseSigma ps{0.012, 0.034, 0.5, 0.01, 1}, ps2;
  ASSERT_EQ(unpack(pack(ps), ps2), DecodeStatus::kOk);
  EXPECT_NEAR(ps2.sigma_x_m, 0.012, 0.0025);
  EXPECT_NEAR(ps2.sigma_z_m, 0.5, 0.0025);
  EXPECT_NEAR(ps2.sigma_yaw_rad, 0.01, 5e-5);

  Heartbeat hb{LocalizerState::kLocalized, 0x5, 3600.4, 17, 200, 12, true}, hb2;
  ASSERT_EQ(unpack(pack(hb), hb2), DecodeStatus::kOk);
  EXPECT_EQ(hb2.state, LocalizerState::kLocalized);
  EXPECT_EQ(hb2.error_flags, 0x5);
  EXPECT_NEAR(hb2.uptime_s, 3600.4, 0.05);
  EXPECT_TRUE(hb2.lidar_timeout);
  EXPECT_EQ(hb2.can_rx_errors, 17);
  EXPECT_EQ(hb2.udp_dropped, 200);
}

TEST(CanMessages, SaturationClampsAndCounts) {
  PackStats stats;
  GnssStatus gs;
  gs.alt_m = 20000.0;        // above 9485.75
  gs.h_acc_m = -1.0;         // below 0
  gs.v_acc_m = std::numeric_limits<double>::quiet_NaN();
  gs.num_sats = 99;          // above 63
  GnssStatus out;
  ASSERT_EQ(unpack(pack(gs, &stats), out), DecodeStatus::kOk);
  EXPECT_EQ(stats.saturated, 4u);
  EXPECT_NEAR(out.alt_m, 9485.75, 1e-9);
  EXPECT_EQ(out.h_acc_m, 0.0);
  EXPECT_EQ(out.v_acc_m, 0.0);
  EXPECT_EQ(out.num_sats, 63);

  PackStats s2;
  GnssDop td{99.0, std::numeric_limits<double>::infinity(), 0};
  GnssDop td2;
  ASSERT_EQ(unpack(pack(td, &s2), td2), DecodeStatus::kOk);
  EXPECT_EQ(s2.saturated, 2u);
  EXPECT_NEAR(td2.hdop, 25.5, 1e-9);
  EXPECT_NEAR(td2.pdop, 25.5, 1e-9);

  // Yaw wraps instead of saturating.
  PackStats s3;
  PoseAttitude pa;
  pa.yaw_rad = 3.0 * 3.14159265358979;  // == pi
  PoseAttitude pa2;
  ASSERT_EQ(unpack(pack(pa, &s3), pa2), DecodeStatus::kOk);
  EXPECT_EQ(s3.saturated, 0u);
  EXPECT_NEAR(std::abs(pa2.yaw_rad), 3.1416, 1e-4);

  PackStats s4;
  pack(VehicleMotion{500.0, -10.0, true, true, 0}, &s4);
  EXPECT_EQ(s4.saturated, 2u);
}

TEST(CanMessages, RejectsWrongIdDlcAndChecksum) {
  const CanFrame good = pack(PosePosition{1.0, 2.0, {}, 4});
  PosePosition out;
  out.x_m = 42.0;
  CanFrame f = good;
  f.id = kPoseAttitudeId;
  EXPECT_EQ(unpack(f, out), DecodeStatus::kWrongId);
  f = good;
  f.dlc = 7;
  EXPECT_EQ(unpack(f, out), DecodeStatus::kWrongDlc);
  // Any single bit flip in bytes 0..7 is caught by the CRC.
  for (int bit = 0; bit < 64; ++bit) {
    f = good;
    f.data[bit / 8] = static_cast<std::uint8_t>(f.data[bit / 8] ^ (1u << (bit % 8)));
    EXPECT_EQ(unpack(f, out), DecodeStatus::kBadChecksum) << bit;
  }
  EXPECT_EQ(out.x_m, 42.0);  // untouched on rejection
  // The same payload under another CRC-protected id fails: the id is in the CRC.
  const CanFrame hb = pack(Heartbeat{});
  CanFrame moved = hb;
  moved.id = kVehicleMotionId;
  VehicleMotion vm;
  EXPECT_EQ(unpack(moved, vm), DecodeStatus::kBadChecksum);
  EXPECT_STREQ(to_string(DecodeStatus::kBadChecksum), "bad checksum");
}

TEST(CanMessages, OutOfRangeRawValuesFlagged) {
  // Raw bit patterns the packer never produces but a faulty sender could.
  CanFrame f = pack(GnssPosition{GnssPositionHalf::kLatitude, 0.0, 0});
  put_bits_le(f.data, 0, 32, static_cast<std::uint32_t>(1000000000));  // 100 deg latitude
  f.data[7] = frame_crc(f.id, f.data);
  GnssPosition gp;
  EXPECT_EQ(unpack(f, gp), DecodeStatus::kOutOfRange);
  EXPECT_NEAR(gp.deg, 100.0, 1e-9);
  // The same bits are a valid longitude: the multiplexer picks the range.
  put_bits_le(f.data, 32, 1, 1);
  f.data[7] = frame_crc(f.id, f.data);
  EXPECT_EQ(unpack(f, gp), DecodeStatus::kOk);
  EXPECT_EQ(gp.half, GnssPositionHalf::kLongitude);

  CanFrame h = pack(Heartbeat{});
  put_bits_le(h.data, 0, 4, 9);  // state 9 does not exist
  h.data[7] = frame_crc(h.id, h.data);
  Heartbeat hb;
  EXPECT_EQ(unpack(h, hb), DecodeStatus::kOutOfRange);
}

// For every message of the table, packed from zeros and from every signal at its maximum: any
// single bit flipped fails the CRC (the GNSS position and time included), and a frame refused for
// its id, DLC or CRC leaves every member of the output as it was.
TEST(CanMessages, EveryMessageIsCrcProtectedAndLeavesItsOutputUntouchedOnRejection) {
  int messages = 0;
  for_each_can_message([&](const auto& layout) {
    using M = typename std::remove_cvref_t<decltype(layout)>::Message;
    ++messages;
    test::Values at_max;
    layout.for_each_field([&](const auto& f) { at_max[f.signal.name] = f.signal.max; });
    M filled;
    test::set_values(layout, at_max, filled);
    const test::Values before = test::values_of(layout, filled);
    for (const CanFrame& good : {pack(M{}), pack(filled)}) {
      EXPECT_EQ(good.data[7], frame_crc(good.id, good.data)) << layout.name;
      std::vector<std::pair<CanFrame, DecodeStatus>> refused;
      CanFrame f = good;
      f.id ^= 0x001u;
      refused.push_back({f, DecodeStatus::kWrongId});
      f = good;
      f.dlc = 7;
      refused.push_back({f, DecodeStatus::kWrongDlc});
      for (int bit = 0; bit < 64; ++bit) {
        f = good;
        f.data[bit / 8] = static_cast<std::uint8_t>(f.data[bit / 8] ^ (1u << (bit % 8)));
        refused.push_back({f, DecodeStatus::kBadChecksum});
      }
      for (const auto& [frame, status] : refused) {
        M out = filled;
        EXPECT_EQ(unpack(frame, out), status) << layout.name;
        EXPECT_EQ(test::values_of(layout, out), before) << layout.name;
      }
      M decoded = filled;
      EXPECT_EQ(unpack(good, decoded), DecodeStatus::kOk) << layout.name;
    }
    M zero_decoded = filled;
    ASSERT_EQ(unpack(pack(M{}), zero_decoded), DecodeStatus::kOk);
    EXPECT_NE(test::values_of(layout, zero_decoded), before) << layout.name << ": a good frame writes";
  });
  EXPECT_EQ(messages, 17);
}

TEST(CanMessages, GnssPositionPairsOnlyConsecutiveHalves) {
  const auto lat = [](double deg, std::uint8_t c) { return GnssPosition{GnssPositionHalf::kLatitude, deg, c}; };
  const auto lon = [](double deg, std::uint8_t c) { return GnssPosition{GnssPositionHalf::kLongitude, deg, c}; };
  using R = GnssPositionPairer::Result;
  GnssPositionPairer p;
  EXPECT_EQ(p.push(lat(48.1, 15)), R::kWaiting);
  EXPECT_EQ(p.push(lon(11.5, 0)), R::kPaired);  // 15 -> 0 wraps
  EXPECT_DOUBLE_EQ(p.lat_deg(), 48.1);
  EXPECT_DOUBLE_EQ(p.lon_deg(), 11.5);
  EXPECT_EQ(p.dropped(), 0u);
  // A longitude alone (its latitude lost), or a second one, pairs with nothing.
  EXPECT_EQ(p.push(lon(11.6, 2)), R::kDropped);
  EXPECT_EQ(p.dropped(), 1u);
  // A latitude whose longitude skipped a counter value: both halves dropped.
  EXPECT_EQ(p.push(lat(48.2, 3)), R::kWaiting);
  EXPECT_EQ(p.push(lon(11.7, 5)), R::kDropped);
  EXPECT_EQ(p.dropped(), 3u);
  // A latitude replaced by the next fix's latitude; then the new pair forms, never old with new.
  EXPECT_EQ(p.push(lat(48.3, 6)), R::kWaiting);
  EXPECT_EQ(p.push(lat(48.4, 8)), R::kWaiting);
  EXPECT_EQ(p.dropped(), 4u);
  EXPECT_EQ(p.push(lon(11.8, 9)), R::kPaired);
  EXPECT_DOUBLE_EQ(p.lat_deg(), 48.4);
  EXPECT_DOUBLE_EQ(p.lon_deg(), 11.8);
  // The fix ends with a latitude waiting: dropped; a longitude after that pairs with nothing.
  EXPECT_EQ(p.push(lat(48.5, 10)), R::kWaiting);
  p.end_fix();
  EXPECT_EQ(p.dropped(), 5u);
  EXPECT_EQ(p.push(lon(11.9, 11)), R::kDropped);
  EXPECT_EQ(p.dropped(), 6u);
  EXPECT_DOUBLE_EQ(p.lat_deg(), 48.4) << "the last pair stays as it was";
}

TEST(CanMessages, RollingCounterMonitor) {
  RollingCounterMonitor mon;
  EXPECT_TRUE(mon.update(14));
  EXPECT_TRUE(mon.update(15));
  EXPECT_TRUE(mon.update(0));   // wraps
  EXPECT_FALSE(mon.update(3));  // 1, 2 lost
  EXPECT_EQ(mon.lost(), 2u);
  EXPECT_FALSE(mon.update(3));  // repeated
  EXPECT_EQ(mon.repeated(), 1u);
  EXPECT_TRUE(mon.update(4));
}

}  // namespace
}  // namespace v2xloc::protocol
