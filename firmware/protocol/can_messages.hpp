// The CAN codec of v2xloc, bit-exact with tools/dbc/v2xloc.dbc (classic CAN, 500 kbit/s, 11-bit ids,
// Intel / little-endian signals): one generic pack() and unpack() over the message table
// (can_message_table.hpp) for every message struct (can_message_types.hpp). Range clamping with a
// saturation count, a 4-bit rolling counter and a CRC-8 (SAE J1850) on every frame.
// Allocation-free, no exceptions: shared by the firmware (also bare metal) and the host tools.
// Formats: firmware/WIRE_FORMATS.md (## CAN).
#pragma once

#include <cstddef>
#include <cstdint>
#include <tuple>
#include <type_traits>
#include <utility>

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

// Field I of M's layout as a compile-time constant (FieldOf<M, I>::value), so that every choice the
// codec makes per signal (its kind, its multiplexer value) is made when compiling.
template <class M, std::size_t I>
struct FieldOf {
  static constexpr const auto& value = std::get<I>(can_layout<M>().fields);
};

// Calls visit(FieldOf<M, I>{}) for every field I of M's layout, in table order.
template <class M, class Visit>
void visit_fields(Visit&& visit) {
  constexpr std::size_t n = std::tuple_size_v<std::remove_cvref_t<decltype(can_layout<M>().fields)>>;
  [&]<std::size_t... I>(std::index_sequence<I...>) { (visit(FieldOf<M, I>{}), ...); }(std::make_index_sequence<n>{});
}

// The value of M's multiplexer (-1 without one): from the struct (the low bits that go on the wire),
// or from a frame's bits.
template <class M>
int mux_of(const M& m) {
  int mux = -1;
  visit_fields<M>([&](auto field) {
    constexpr const CanSignal& s = decltype(field)::value.signal;
    if constexpr (s.kind == SignalKind::kMultiplexer) {
      const std::uint64_t mask = (std::uint64_t{1} << s.length) - 1u;
      mux = static_cast<int>(static_cast<std::uint64_t>(to_physical(decltype(field)::value.of(m))) & mask);
    }
  });
  return mux;
}
template <class M>
int mux_in(const std::uint8_t* data) {
  int mux = -1;
  visit_fields<M>([&](auto field) {
    constexpr const CanSignal& s = decltype(field)::value.signal;
    bool ignored = false;
    if constexpr (s.kind == SignalKind::kMultiplexer) mux = static_cast<int>(get_signal(data, s, ignored));
  });
  return mux;
}
}  // namespace detail

// Packing never fails: out-of-range values are clamped (counted in stats, if given); a frame's
// clamped flag (RegClamped, OdomClamped) is also set when any other of its signals was clamped.
template <CanMessage M>
CanFrame pack(const M& m, PackStats* stats = nullptr) {
  CanFrame f = detail::start_frame(can_layout<M>().id);
  const int mux = detail::mux_of(m);
  std::uint32_t saturated = 0;
  detail::visit_fields<M>([&](auto field) {
    constexpr const CanSignal& s = decltype(field)::value.signal;
    if constexpr (s.kind != SignalKind::kClampedFlag) {
      if (s.carried(mux)) saturated += detail::put_signal(f.data, s, to_physical(decltype(field)::value.of(m))) ? 1u : 0u;
    }
  });
  detail::visit_fields<M>([&](auto field) {
    constexpr const CanSignal& s = decltype(field)::value.signal;
    if constexpr (s.kind == SignalKind::kClampedFlag) {
      const bool clamped = decltype(field)::value.of(m) || saturated != 0u;
      detail::put_signal(f.data, s, clamped ? 1.0 : 0.0);
    }
  });
  if (stats != nullptr) stats->saturated += saturated;
  detail::seal(f);
  return f;
}

// Unpacking checks id, DLC (exactly 8), CRC, and DBC ranges. On kWrongId / kWrongDlc /
// kBadChecksum the output is left untouched; on kOutOfRange every value is written.
template <CanMessage M>
DecodeStatus unpack(const CanFrame& f, M& m) {
  const DecodeStatus checked = detail::check_frame(f, can_layout<M>().id);
  if (checked != DecodeStatus::kOk) return checked;
  const int mux = detail::mux_in<M>(f.data);
  bool out_of_range = false;
  detail::visit_fields<M>([&](auto field) {
    constexpr const CanSignal& s = decltype(field)::value.signal;
    if (s.carried(mux)) assign_physical(decltype(field)::value.of(m), detail::get_signal(f.data, s, out_of_range));
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
