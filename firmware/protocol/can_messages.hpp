// The CAN codec of v2xloc, bit-exact with tools/dbc/v2xloc.dbc (classic CAN, 500 kbit/s, 11-bit ids,
// Intel / little-endian signals): one generic pack() and unpack() over the message table
// (can_message_table.hpp) for every message struct (can_message_types.hpp). Range clamping with a
// saturation count, a 4-bit rolling counter and a CRC-8 (SAE J1850) on every frame.
// Allocation-free, no exceptions: shared by the firmware (also bare metal) and the host tools.
// Formats: firmware/WIRE_FORMATS.md (## CAN).
#pragma once

#include <cstdint>

#include "firmware/protocol/can_message_table.hpp"
#include "firmware/protocol/can_message_types.hpp"
#include "hal/can_frame.hpp"

namespace v2xloc::protocol {

using hal::CanFrame;  // the frame type belongs to the hardware layer; codecs fill it

enum class DecodeStatus : std::uint8_t {
  kOk = 0,
  kWrongId,
  kWrongDlc,
  kBadChecksum,
  kOutOfRange,  // decoded, but a signal lies outside its DBC [min|max] (values are still written)
};

const char* to_string(DecodeStatus status);

// CRC-8 SAE J1850: poly 0x1D, init 0xFF, final XOR 0xFF (check value "123456789" -> 0x4B).
std::uint8_t crc8_j1850(const std::uint8_t* data, std::uint32_t length, std::uint8_t init = 0xFF);
// The frame CRC covers the 11-bit id (low byte, then high byte: a frame replayed under another id
// fails) and data bytes 0..6; it sits in byte 7.
std::uint8_t frame_crc(std::uint32_t id, const std::uint8_t* data);

// Counts signals clamped into their DBC range (or NaN replaced) while packing.
struct PackStats {
  std::uint32_t saturated = 0;
};

namespace detail {
// The steps of pack() and unpack() that do not depend on the message (can_messages.cpp).
CanFrame start_frame(std::uint32_t id);
void seal(CanFrame& f);  // the CRC into byte 7
// kWrongId, kWrongDlc (not 8), kBadChecksum or kOk.
DecodeStatus check_frame(const CanFrame& f, std::uint32_t id);
// Writes a signal's physical value as its kind says; returns whether the value had to be clamped.
bool put_signal(std::uint8_t* data, const CanSignal& s, double physical);
// Reads a signal; sets out_of_range for a scaled value outside [min, max] (half a step of tolerance).
double get_signal(const std::uint8_t* data, const CanSignal& s, bool& out_of_range);

// The value of the layout's multiplexer (-1 without one): from the struct (the low bits that go on
// the wire), or from a frame's bits.
template <class Layout, class M>
int mux_of(const Layout& layout, const M& m) {
  int mux = -1;
  layout.for_each_field([&](const auto& f) {
    const std::uint64_t mask = (std::uint64_t{1} << f.signal.length) - 1u;
    if (f.signal.kind == SignalKind::kMultiplexer)
      mux = static_cast<int>(static_cast<std::uint64_t>(to_physical(f.of(m))) & mask);
  });
  return mux;
}
template <class Layout>
int mux_in(const Layout& layout, const std::uint8_t* data) {
  int mux = -1;
  bool ignored = false;
  layout.for_each_field([&](const auto& f) {
    if (f.signal.kind == SignalKind::kMultiplexer) mux = static_cast<int>(get_signal(data, f.signal, ignored));
  });
  return mux;
}
}  // namespace detail

// Packing never fails: out-of-range values are clamped (counted in stats, if given); a frame's
// clamped flag (RegClamped, OdomClamped) is also set when any other of its signals was clamped.
template <CanMessage M>
CanFrame pack(const M& m, PackStats* stats = nullptr) {
  constexpr const auto& layout = can_layout<M>();
  CanFrame f = detail::start_frame(layout.id);
  const int mux = detail::mux_of(layout, m);
  std::uint32_t saturated = 0;
  layout.for_each_field([&](const auto& field) {
    if (field.signal.kind != SignalKind::kClampedFlag && field.signal.carried(mux))
      saturated += detail::put_signal(f.data, field.signal, to_physical(field.of(m))) ? 1u : 0u;
  });
  layout.for_each_field([&](const auto& field) {
    if (field.signal.kind == SignalKind::kClampedFlag)
      detail::put_signal(f.data, field.signal, to_physical(field.of(m)) != 0.0 || saturated != 0u ? 1.0 : 0.0);
  });
  if (stats != nullptr) stats->saturated += saturated;
  detail::seal(f);
  return f;
}

// Unpacking checks id, DLC (exactly 8), CRC, and DBC ranges. On kWrongId / kWrongDlc /
// kBadChecksum the output is left untouched; on kOutOfRange every value is written.
template <CanMessage M>
DecodeStatus unpack(const CanFrame& f, M& m) {
  constexpr const auto& layout = can_layout<M>();
  const DecodeStatus checked = detail::check_frame(f, layout.id);
  if (checked != DecodeStatus::kOk) return checked;
  const int mux = detail::mux_in(layout, f.data);
  bool out_of_range = false;
  layout.for_each_field([&](const auto& field) {
    if (field.signal.carried(mux)) assign_physical(field.of(m), detail::get_signal(f.data, field.signal, out_of_range));
  });
  return out_of_range ? DecodeStatus::kOutOfRange : DecodeStatus::kOk;
}

// Receiver-side rolling-counter supervision (one per message id): counts frames lost in between
// and repeated (stale) frames.
class RollingCounterMonitor {
 public:
  // Returns true when the counter advanced by exactly one (or on the first frame).
  bool update(std::uint8_t counter);
  std::uint32_t lost() const { return lost_; }
  std::uint32_t repeated() const { return repeated_; }

 private:
  std::uint8_t last_ = 0;
  bool seen_ = false;
  std::uint32_t lost_ = 0, repeated_ = 0;
};

// A fix's position from its two 0x130 frames (frames that passed the CRC, range and rolling-counter
// checks, in receive order): a latitude, then the longitude with the next counter value. Nothing
// else pairs: a longitude without the latitude just before it, or after a counter jump, and a
// latitude that another latitude or the end of the fix replaces, are dropped and counted, so a new
// latitude is never combined with an older longitude (or the reverse).
class GnssPositionPairer {
 public:
  enum class Result : std::uint8_t { kWaiting, kPaired, kDropped };
  Result push(const GnssPosition& half);
  // The fix closed (its time frame): a latitude still waiting for its longitude is dropped.
  void end_fix();
  // The position of the latest kPaired (both in degrees).
  double lat_deg() const { return lat_deg_; }
  double lon_deg() const { return lon_deg_; }
  std::uint32_t dropped() const { return dropped_; }  // halves that formed no position

 private:
  bool waiting_ = false;
  std::uint8_t lat_counter_ = 0;
  double pending_lat_deg_ = 0.0, lat_deg_ = 0.0, lon_deg_ = 0.0;
  std::uint32_t dropped_ = 0;
};

// Bit-level helpers (Intel byte order, DBC start bit = LSB), exposed for the DBC conformance test.
void put_bits_le(std::uint8_t* data, unsigned start_bit, unsigned length, std::uint64_t raw);
std::uint64_t get_bits_le(const std::uint8_t* data, unsigned start_bit, unsigned length);

}  // namespace v2xloc::protocol
