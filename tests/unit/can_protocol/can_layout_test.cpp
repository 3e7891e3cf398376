// CAN layout 1 -> 2 conversion (host_sim/canlog/can_layout.hpp): a recorded layout-1 log, converted,
// is a valid layout-2 log (CRC, counters as a sender steps them, fix order) and the firmware's
// decoder hands the localizer bit-identical numbers to what layout 1's codec decoded.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "firmware/protocol/can_messages.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "host_sim/canlog/can_layout.hpp"

namespace v2xloc::sim {
namespace {

namespace p = protocol;

// Layout 1 as it was on the wire: 0x130 Latitude 0|32 + Longitude 32|32 (signed, 1e-7 deg), 0x132
// TimeOfWeek 0|32 (1 ms) + Week 32|16 + Hdop 48|8 + Pdop 56|8 (0.1); no counter, no CRC.
struct LegacyFix {
  std::int32_t lat_raw = 0, lon_raw = 0;
  std::uint32_t tow_raw = 0;
  std::uint16_t week = 0;
  std::uint8_t hdop_raw = 0, pdop_raw = 0;
};

CandumpRecord record(std::int64_t us, const hal::CanFrame& f) {
  CandumpRecord r;
  r.timestamp_us = us;
  r.frame = f;
  return r;
}

hal::CanFrame legacy_position(const LegacyFix& x) {
  hal::CanFrame f;
  f.id = p::kGnssPositionId;
  f.dlc = 8;
  p::put_bits_le(f.data, 0, 32, static_cast<std::uint32_t>(x.lat_raw));
  p::put_bits_le(f.data, 32, 32, static_cast<std::uint32_t>(x.lon_raw));
  return f;
}

hal::CanFrame legacy_time(const LegacyFix& x) {
  hal::CanFrame f;
  f.id = p::kGnssTimeId;
  f.dlc = 8;
  p::put_bits_le(f.data, 0, 32, x.tow_raw);
  p::put_bits_le(f.data, 32, 16, x.week);
  p::put_bits_le(f.data, 48, 8, x.hdop_raw);
  p::put_bits_le(f.data, 56, 8, x.pdop_raw);
  return f;
}

// Layout 1's decode of a raw value (the codec's formula then: raw * factor + offset).
double legacy_value(std::int64_t raw, double factor) { return static_cast<double>(raw) * factor + 0.0; }

// A recorded layout-1 log: per fix (5 Hz) vehicle motion, position, status, velocity, time.
std::vector<CandumpRecord> legacy_log(const std::vector<LegacyFix>& fixes) {
  std::vector<CandumpRecord> log;
  for (std::size_t k = 0; k < fixes.size(); ++k) {
    const std::int64_t us = 1'700'000'000'000'000 + 200'000 * static_cast<std::int64_t>(k);
    const auto c = static_cast<std::uint8_t>(k % p::kCounterModulo);
    p::GnssStatus st;
    st.fix_type = p::GnssFixType::kFix3D;
    st.alt_m = 520.0;
    st.counter = c;
    p::GnssVelocity vel;
    vel.counter = c;
    log.push_back(record(us, p::pack(p::VehicleMotion{1.0, 0.0, true, true, c})));
    log.push_back(record(us, legacy_position(fixes[k])));
    log.push_back(record(us, p::pack(st)));
    log.push_back(record(us, p::pack(vel)));
    log.push_back(record(us, legacy_time(fixes[k])));
  }
  return log;
}

std::vector<LegacyFix> random_fixes(std::size_t n) {
  std::mt19937 rng(2026);
  std::uniform_int_distribution<std::int32_t> lat(-900'000'000, 900'000'000), lon(-1'800'000'000, 1'800'000'000);
  std::uniform_int_distribution<std::uint32_t> tow(0, 604'799'999);
  std::uniform_int_distribution<int> byte(0, 255), week(0, 65535);
  std::vector<LegacyFix> fixes(n);
  for (LegacyFix& f : fixes) {
    f = {lat(rng), lon(rng), tow(rng), static_cast<std::uint16_t>(week(rng)), static_cast<std::uint8_t>(byte(rng)),
         static_cast<std::uint8_t>(byte(rng))};
  }
  fixes[0] = {900'000'000, -1'800'000'000, 604'799'999, 65535, 255, 0};  // the range ends
  fixes[1] = {-900'000'000, 1'800'000'000, 0, 0, 0, 255};
  return fixes;
}

TEST(CanLayout, ConvertedLogIsLayoutTwoWithCountersInFixOrder) {
  const std::vector<LegacyFix> fixes = random_fixes(20);
  std::vector<CandumpRecord> log = legacy_log(fixes);
  const CanLayoutConversion done = convert_can_layout_1_to_2(log);
  EXPECT_EQ(done.positions, fixes.size());
  EXPECT_EQ(done.times, fixes.size());
  EXPECT_EQ(done.kept, 0u);
  ASSERT_EQ(log.size(), fixes.size() * 7);
  for (std::size_t k = 0; k < fixes.size(); ++k) {
    const CandumpRecord* r = &log[7 * k];
    const std::uint32_t ids[7] = {p::kVehicleMotionId, p::kGnssPositionId, p::kGnssPositionId, p::kGnssStatusId,
                                  p::kGnssVelocityId, p::kGnssDopId, p::kGnssTimeId};
    for (int i = 0; i < 7; ++i) {
      EXPECT_EQ(r[i].frame.id, ids[i]) << k << " " << i;
      EXPECT_EQ(r[i].timestamp_us, r[0].timestamp_us) << "every frame keeps its fix's stamp";
    }
    p::GnssPosition lat, lon;
    p::GnssDop dop;
    p::GnssTime time;
    ASSERT_EQ(p::unpack(r[1].frame, lat), p::DecodeStatus::kOk);
    ASSERT_EQ(p::unpack(r[2].frame, lon), p::DecodeStatus::kOk);
    ASSERT_EQ(p::unpack(r[5].frame, dop), p::DecodeStatus::kOk);
    ASSERT_EQ(p::unpack(r[6].frame, time), p::DecodeStatus::kOk);
    EXPECT_EQ(lat.half, p::GnssPositionHalf::kLatitude);
    EXPECT_EQ(lon.half, p::GnssPositionHalf::kLongitude);
    EXPECT_EQ(unsigned{lat.counter}, (2 * k) % 16);
    EXPECT_EQ(unsigned{lon.counter}, (2 * k + 1) % 16);
    EXPECT_EQ(unsigned{dop.counter}, k % 16);
    EXPECT_EQ(unsigned{time.counter}, k % 16);
    // The same bits, so the same doubles as layout 1's decode.
    EXPECT_EQ(lat.deg, legacy_value(fixes[k].lat_raw, 1e-7));
    EXPECT_EQ(lon.deg, legacy_value(fixes[k].lon_raw, 1e-7));
    EXPECT_EQ(time.time_of_week_s, legacy_value(fixes[k].tow_raw, 0.001));
    EXPECT_EQ(time.week, fixes[k].week);
    EXPECT_EQ(dop.hdop, legacy_value(fixes[k].hdop_raw, 0.1));
    EXPECT_EQ(dop.pdop, legacy_value(fixes[k].pdop_raw, 0.1));
  }
}

TEST(CanLayout, FirmwareDecoderGetsBitIdenticalFixesFromAConvertedLog) {
  const std::vector<LegacyFix> fixes = random_fixes(40);
  std::vector<CandumpRecord> log = legacy_log(fixes);
  convert_can_layout_1_to_2(log);
  auto decoder = std::make_unique<firmware::InputDecoder>(0);
  std::vector<GnssInput> got;
  std::vector<p::GnssTime> times;
  for (const CandumpRecord& r : log) {
    const firmware::DecodedCan d = decoder->decode_can(r.frame, 0);
    EXPECT_NE(d.kind, firmware::CanInputKind::kRejected) << std::hex << r.frame.id;
    EXPECT_NE(d.kind, firmware::CanInputKind::kInvalid) << std::hex << r.frame.id;
    if (d.kind == firmware::CanInputKind::kGnssFix) {
      got.push_back(d.gnss);
      times.push_back(decoder->can().last_gnss_time());
    }
  }
  ASSERT_EQ(got.size(), fixes.size());
  for (std::size_t k = 0; k < fixes.size(); ++k) {
    EXPECT_TRUE(got[k].valid);
    EXPECT_EQ(got[k].lat_deg, legacy_value(fixes[k].lat_raw, 1e-7)) << k;
    EXPECT_EQ(got[k].lon_deg, legacy_value(fixes[k].lon_raw, 1e-7)) << k;
    EXPECT_EQ(got[k].hdop, legacy_value(fixes[k].hdop_raw, 0.1)) << k;
    EXPECT_EQ(times[k].time_of_week_s, legacy_value(fixes[k].tow_raw, 0.001)) << k;
    EXPECT_EQ(times[k].week, fixes[k].week) << k;
  }
  const firmware::CanCounters& c = decoder->can().counters();
  EXPECT_EQ(c.can_rejected + c.can_repeated + c.can_counter_gaps + c.gnss_position_dropped + c.gnss_incomplete, 0u);
}

// What layout 1 refused stays refused: a wrong DLC is kept as it was, an out-of-range latitude
// keeps its bits (so its range check fails again); other ids pass through untouched.
TEST(CanLayout, RefusedLegacyFramesStayRefused) {
  LegacyFix bad;
  bad.lat_raw = 1'000'000'000;  // 100 deg
  hal::CanFrame short_time = legacy_time(LegacyFix{});
  short_time.dlc = 6;
  hal::CanFrame other;
  other.id = 0x7AB;
  other.dlc = 3;
  other.data[0] = 0x42;
  std::vector<CandumpRecord> log = {record(1, legacy_position(bad)), record(2, short_time), record(3, other)};
  const CanLayoutConversion done = convert_can_layout_1_to_2(log);
  EXPECT_EQ(done.positions, 1u);
  EXPECT_EQ(done.kept, 1u);
  ASSERT_EQ(log.size(), 4u);
  p::GnssPosition lat;
  EXPECT_EQ(p::unpack(log[0].frame, lat), p::DecodeStatus::kOutOfRange);
  p::GnssTime t;
  EXPECT_EQ(p::unpack(log[2].frame, t), p::DecodeStatus::kWrongDlc);
  EXPECT_EQ(log[3].frame.id, 0x7ABu);
  EXPECT_EQ(log[3].frame.dlc, 3);
  EXPECT_EQ(log[3].frame.data[0], 0x42);
}

}  // namespace
}  // namespace v2xloc::sim
