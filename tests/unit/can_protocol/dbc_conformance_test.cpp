// CAN frames match tools/dbc/v2xloc.dbc: every signal of every message, random physical values,
// read back with an independent DBC reading of the bits.
#include <gtest/gtest.h>

#include <random>

#include "dbc_reader.hpp"
#include "message_bindings.hpp"

namespace v2xloc::test {
namespace {

std::string dbc_path() { return std::string(V2XLOC_SOURCE_DIR) + "/tools/dbc/v2xloc.dbc"; }

TEST(DbcConformance, FileDescribesEveryMessage) {
  const Dbc dbc = read_dbc(dbc_path());
  EXPECT_EQ(dbc.baudrate, 500000);
  const auto bindings = message_bindings();
  ASSERT_EQ(dbc.messages.size(), bindings.size());
  for (const auto& b : bindings) {
    ASSERT_TRUE(dbc.messages.count(b.id)) << std::hex << b.id;
    const DbcMessage& m = dbc.messages.at(b.id);
    EXPECT_EQ(m.dlc, 8u);
    EXPECT_LE(m.id, 0x7FFu);
    // The signals of a frame (per multiplexer value) do not overlap and fit into 64 bits; all Intel
    // byte order. Every inbound and outbound frame ends in the 4-bit rolling counter and the CRC.
    for (const int mux : m.mux_values()) {
      std::uint64_t used = 0;
      for (const auto& [name, s] : m.active(mux)) {
        EXPECT_TRUE(s.little_endian) << name;
        ASSERT_LE(s.start + s.length, 64u) << name;
        for (unsigned i = s.start; i < s.start + s.length; ++i) {
          EXPECT_FALSE((used >> i) & 1u) << m.name << "." << name << " overlaps at bit " << i << " (mux " << mux << ")";
          used |= std::uint64_t{1} << i;
        }
      }
    }
    ASSERT_TRUE(m.signals.count("Crc")) << m.name;
    EXPECT_EQ(m.signals.at("Crc").start, 56u) << m.name;
    EXPECT_EQ(m.signals.at("Crc").length, 8u) << m.name;
    ASSERT_TRUE(m.signals.count("Counter")) << m.name;
    EXPECT_EQ(m.signals.at("Counter").length, 4u) << m.name;
    EXPECT_EQ(m.signals.at("Counter").mux_value, -1) << m.name << ": every frame of the id carries the counter";
  }
}

// The codec's message table is the DBC's, message by message and signal by signal (the CRC in byte
// 7 aside): one source of truth, any drift fails.
TEST(DbcConformance, CodecTableEqualsDbc) {
  const Dbc dbc = read_dbc(dbc_path());
  std::size_t messages = 0;
  protocol::for_each_can_message([&](const auto& layout) {
    ++messages;
    ASSERT_TRUE(dbc.messages.count(layout.id)) << std::hex << layout.id << " " << layout.name;
    const DbcMessage& m = dbc.messages.at(layout.id);
    EXPECT_EQ(m.name, layout.name);
    std::size_t signals = 0;
    layout.for_each_field([&](const auto& field) {
      const protocol::CanSignal& c = field.signal;
      const std::string where = m.name + "." + c.name;
      ++signals;
      ASSERT_TRUE(m.signals.count(c.name)) << where << " is not in the DBC";
      const DbcSignal& s = m.signals.at(c.name);
      EXPECT_EQ(c.start, s.start) << where;
      EXPECT_EQ(c.length, s.length) << where;
      EXPECT_EQ(c.is_signed, s.is_signed) << where;
      EXPECT_TRUE(s.little_endian) << where;
      EXPECT_DOUBLE_EQ(c.factor, s.factor) << where;
      EXPECT_DOUBLE_EQ(c.offset, s.offset) << where;
      EXPECT_DOUBLE_EQ(c.min, s.min) << where;
      EXPECT_DOUBLE_EQ(c.max, s.max) << where;
      EXPECT_EQ(c.mux, s.mux_value) << where;
      EXPECT_EQ(c.kind == protocol::SignalKind::kMultiplexer, s.multiplexer) << where;
      EXPECT_EQ(c.kind == protocol::SignalKind::kCounter, c.name == std::string("Counter")) << where;
    });
    EXPECT_EQ(signals + 1, m.signals.size()) << m.name << ": every DBC signal but the CRC is in the table";
  });
  EXPECT_EQ(messages, dbc.messages.size());
}

// The physical values of one frame: the multiplexer (if any) set to `mux`.
Values mux_values_in(const DbcMessage& m, int mux) {
  Values in;
  if (const DbcSignal* mx = m.multiplexer()) in[mx->name] = mux;
  return in;
}

// The test bindings name exactly the DBC's signals (CRC aside), both ways, per multiplexer value.
TEST(DbcConformance, BindingsNameExactlyTheDbcSignals) {
  const Dbc dbc = read_dbc(dbc_path());
  for (const auto& b : message_bindings()) {
    const DbcMessage& m = dbc.messages.at(b.id);
    for (const int mux : m.mux_values()) {
      const auto active = m.active(mux);
      Values decoded;
      b.unpack(b.pack(mux_values_in(m, mux), nullptr), decoded);
      for (const auto& [name, s] : active) {
        if (name == "Crc") continue;
        EXPECT_TRUE(decoded.count(name)) << m.name << "." << name << " has no binding (mux " << mux << ")";
      }
      for (const auto& [name, v] : decoded)
        EXPECT_TRUE(active.count(name)) << m.name << "." << name << " is not in the DBC (mux " << mux << ")";
    }
  }
}

TEST(DbcConformance, RandomPhysicalValuesMatchDbcScaling) {
  const Dbc dbc = read_dbc(dbc_path());
  std::mt19937_64 rng(20261123);
  for (const auto& b : message_bindings()) {
    const DbcMessage& m = dbc.messages.at(b.id);
    const std::vector<int> muxes = m.mux_values();
    for (int trial = 0; trial < 300; ++trial) {
      const int mux = muxes[static_cast<std::size_t>(trial) % muxes.size()];
      const auto signals = m.active(mux);
      Values in = mux_values_in(m, mux);
      for (const auto& [name, s] : signals) {
        if (name == "Crc" || in.count(name)) continue;
        std::uniform_real_distribution<double> u(s.min, s.max);
        double v = u(rng);
        if (s.factor == 1.0) v = std::round(v);  // integer-valued signals (counters, enums, flags)
        in[name] = v;
      }
      protocol::PackStats stats;
      const hal::CanFrame f = b.pack(in, &stats);
      EXPECT_EQ(stats.saturated, 0u) << m.name;
      ASSERT_EQ(f.id, m.id);
      ASSERT_EQ(f.dlc, m.dlc);
      // Bits outside every DBC signal stay zero.
      std::uint64_t covered = 0, payload = 0;
      for (const auto& [name, s] : signals) {
        for (unsigned i = s.start; i < s.start + s.length; ++i) covered |= std::uint64_t{1} << i;
      }
      for (int i = 0; i < 8; ++i) payload |= static_cast<std::uint64_t>(f.data[i]) << (8 * i);
      EXPECT_EQ(payload & ~covered, 0u) << m.name;
      Values decoded;
      EXPECT_EQ(b.unpack(f, decoded), protocol::DecodeStatus::kOk) << m.name;
      for (const auto& [name, s] : signals) {
        const double dbc_value = s.decode(f.data);
        if (name == "Crc") {
          EXPECT_EQ(static_cast<int>(dbc_value), protocol::frame_crc(f.id, f.data)) << m.name;
          continue;
        }
        // The DBC reading of the bits equals the physical input to within half a resolution step,
        // and the codec's own decode agrees with the DBC reading.
        EXPECT_NEAR(dbc_value, in.at(name), 0.5 * s.factor + 1e-9) << m.name << "." << name;
        ASSERT_TRUE(decoded.count(name)) << m.name << "." << name;
        EXPECT_NEAR(decoded.at(name), dbc_value, 1e-9 * std::max(1.0, std::abs(dbc_value))) << m.name << "." << name;
        EXPECT_GE(dbc_value, s.min - 0.5 * s.factor);
        EXPECT_LE(dbc_value, s.max + 0.5 * s.factor);
      }
    }
  }
}

}  // namespace
}  // namespace v2xloc::test
