#include "host_sim/canlog/can_layout.hpp"

#include <cstdint>
#include <cstring>
#include <utility>

#include "firmware/protocol/can_messages.hpp"

namespace v2xloc::sim {
namespace {

namespace p = protocol;

// Layout 1's bits (Intel order): 0x130 Latitude 0|32, Longitude 32|32; 0x132 TimeOfWeek 0|32,
// Week 32|16, Hdop 48|8, Pdop 56|8.
struct LegacyPosition {
  std::uint64_t lat = 0, lon = 0;
};
struct LegacyTime {
  std::uint64_t tow = 0, week = 0, hdop = 0, pdop = 0;
};

// Writes raw bits into the current layout's signal `name` of f.id (the codec's table, which the
// DBC conformance test holds to the DBC) and seals the frame again.
void put_raw(hal::CanFrame& f, const char* name, std::uint64_t raw) {
  for (const p::NamedCanSignal& s : p::can_signal_table()) {
    if (s.message_id == f.id && std::strcmp(s.name, name) == 0) p::put_bits_le(f.data, s.start, s.length, raw);
  }
  f.data[7] = p::frame_crc(f.id, f.data);
}

CandumpRecord with_frame(const CandumpRecord& like, const hal::CanFrame& frame) {
  CandumpRecord r = like;
  r.frame = frame;
  return r;
}

std::uint8_t step(std::uint8_t& counter) {
  const std::uint8_t now = counter;
  counter = static_cast<std::uint8_t>((counter + 1) % p::kCounterModulo);
  return now;
}

void append_position(const CandumpRecord& r, std::uint8_t& counter, std::vector<CandumpRecord>& out) {
  const LegacyPosition old{p::get_bits_le(r.frame.data, 0, 32), p::get_bits_le(r.frame.data, 32, 32)};
  hal::CanFrame lat = p::pack(p::GnssPosition{p::GnssPositionHalf::kLatitude, 0.0, step(counter)});
  put_raw(lat, "Latitude", old.lat);
  hal::CanFrame lon = p::pack(p::GnssPosition{p::GnssPositionHalf::kLongitude, 0.0, step(counter)});
  put_raw(lon, "Longitude", old.lon);
  out.push_back(with_frame(r, lat));
  out.push_back(with_frame(r, lon));
}

void append_time(const CandumpRecord& r, std::uint8_t& counter, std::vector<CandumpRecord>& out) {
  const std::uint8_t* d = r.frame.data;
  const LegacyTime old{p::get_bits_le(d, 0, 32), p::get_bits_le(d, 32, 16), p::get_bits_le(d, 48, 8),
                       p::get_bits_le(d, 56, 8)};
  const std::uint8_t fix = step(counter);
  hal::CanFrame dop = p::pack(p::GnssDop{0.0, 0.0, fix});
  put_raw(dop, "Hdop", old.hdop);
  put_raw(dop, "Pdop", old.pdop);
  hal::CanFrame time = p::pack(p::GnssTime{0.0, 0, fix});
  put_raw(time, "TimeOfWeek", old.tow);
  put_raw(time, "Week", old.week);
  out.push_back(with_frame(r, dop));  // the DOP precedes the time frame that closes the fix
  out.push_back(with_frame(r, time));
}

}  // namespace

CanLayoutConversion convert_can_layout_1_to_2(std::vector<CandumpRecord>& records) {
  CanLayoutConversion stats;
  std::vector<CandumpRecord> out;
  out.reserve(records.size() + records.size() / 4);
  std::uint8_t position_counter = 0, fix_counter = 0;
  for (CandumpRecord& r : records) {
    const bool legacy = r.frame.id == p::kGnssPositionId || r.frame.id == p::kGnssTimeId;
    if (legacy && r.frame.dlc != 8) ++stats.kept;
    if (!legacy || r.frame.dlc != 8) {
      out.push_back(std::move(r));
    } else if (r.frame.id == p::kGnssPositionId) {
      append_position(r, position_counter, out);
      ++stats.positions;
    } else {
      append_time(r, fix_counter, out);
      ++stats.times;
    }
  }
  records = std::move(out);
  return stats;
}

}  // namespace v2xloc::sim
