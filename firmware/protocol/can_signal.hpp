// Building blocks of the CAN message table (can_message_table.hpp): a DBC signal (CanSignal), a
// struct member bound to it (field) and a message as the list of its bound fields (message). All
// constexpr, no allocation: the codec (can_messages.hpp) and the tests walk the same description.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <tuple>
#include <type_traits>

namespace v2xloc::protocol {

// How a signal is packed and read. Every signal is Intel byte order (DBC start bit = LSB).
enum class SignalKind : std::uint8_t {
  kScaled,       // physical = raw * factor + offset; packing clamps into [min, max] (a NaN becomes the
                 // in-range value nearest zero) and counts it, reading flags a value outside the range
  kAngle,        // kScaled, but a finite angle is wrapped to [-pi, pi] before packing, not clamped
  kFlag,         // one bit
  kCounter,      // the 4-bit rolling counter, packed modulo 16
  kMultiplexer,  // selects which multiplexed signals the frame carries
  kClampedFlag,  // one bit, set by the sender or when any other signal of the frame saturated
};

enum class Sign : std::uint8_t { kUnsigned, kSigned };

// One DBC signal (`SG_ name [m<mux>] : start|length@1sign (factor,offset) [min|max]`).
struct CanSignal {
  const char* name = nullptr;
  unsigned start = 0;
  unsigned length = 0;
  bool is_signed = false;
  double factor = 1.0;
  double offset = 0.0;
  double min = 0.0;
  double max = 0.0;
  SignalKind kind = SignalKind::kScaled;
  int mux = -1;  // carried only while the multiplexer reads this value; -1: always

  constexpr bool carried(int frame_mux) const { return mux < 0 || mux == frame_mux; }
};

constexpr CanSignal scaled(const char* name, unsigned start, unsigned length, Sign sign, double factor, double offset,
                           double min, double max) {
  return {name, start, length, sign == Sign::kSigned, factor, offset, min, max, SignalKind::kScaled};
}
constexpr CanSignal angle(const char* name, unsigned start, unsigned length, double factor, double limit) {
  return {name, start, length, true, factor, 0.0, -limit, limit, SignalKind::kAngle};
}
// An unsigned integer signal (factor 1, offset 0) of range [0, max].
constexpr CanSignal integer(const char* name, unsigned start, unsigned length, double max) {
  return {name, start, length, false, 1.0, 0.0, 0.0, max, SignalKind::kScaled};
}
constexpr CanSignal flag(const char* name, unsigned bit) {
  return {name, bit, 1, false, 1.0, 0.0, 0.0, 1.0, SignalKind::kFlag};
}
constexpr CanSignal clamped_flag(const char* name, unsigned bit) {
  return {name, bit, 1, false, 1.0, 0.0, 0.0, 1.0, SignalKind::kClampedFlag};
}
constexpr CanSignal multiplexer(const char* name, unsigned bit) {
  return {name, bit, 1, false, 1.0, 0.0, 0.0, 1.0, SignalKind::kMultiplexer};
}
constexpr CanSignal rolling_counter(unsigned start) {
  return {"Counter", start, 4, false, 1.0, 0.0, 0.0, 15.0, SignalKind::kCounter};
}
constexpr CanSignal multiplexed(CanSignal s, int mux) {
  s.mux = mux;
  return s;
}

// A member of message struct M (bool, integer, enum or double) carried by one signal; `Outer` is
// set for a member of a nested struct (the pose flags).
template <class M, class T, class Outer = void>
struct Field {
  using Value = T;
  T Outer::*member;
  Outer M::*outer;
  CanSignal signal;

  constexpr T& of(M& m) const { return (m.*outer).*member; }
  constexpr const T& of(const M& m) const { return (m.*outer).*member; }
};

template <class M, class T>
struct Field<M, T, void> {
  using Value = T;
  T M::*member;
  CanSignal signal;

  constexpr T& of(M& m) const { return m.*member; }
  constexpr const T& of(const M& m) const { return m.*member; }
};

template <class M, class T>
constexpr Field<M, T> field(T M::*member, CanSignal signal) {
  return {member, signal};
}
template <class M, class Outer, class T>
constexpr Field<M, T, Outer> field(Outer M::*outer, T Outer::*member, CanSignal signal) {
  return {member, outer, signal};
}

// One message: its id, DBC name and every signal but the CRC (byte 7), each bound to its member.
template <class M, class... Fields>
struct CanMessageLayout {
  using Message = M;
  std::uint32_t id;
  const char* name;
  std::tuple<Fields...> fields;

  template <class Visit>
  constexpr void for_each_field(Visit&& visit) const {
    std::apply([&](const auto&... f) { (visit(f), ...); }, fields);
  }
};

template <class M, class... Fields>
constexpr CanMessageLayout<M, Fields...> message(std::uint32_t id, const char* name, Fields... fields) {
  return {id, name, std::tuple<Fields...>{fields...}};
}

// A member's value as the signal's physical value, and back (enums by their underlying value).
template <class T>
constexpr double to_physical(T value) {
  if constexpr (std::is_enum_v<T>) return static_cast<double>(static_cast<std::underlying_type_t<T>>(value));
  else if constexpr (std::is_same_v<T, bool>) return value ? 1.0 : 0.0;
  else return static_cast<double>(value);
}

template <class T>
constexpr void assign_physical(T& out, double value) {
  if constexpr (std::is_enum_v<T>) out = static_cast<T>(static_cast<std::underlying_type_t<T>>(value));
  else if constexpr (std::is_same_v<T, bool>) out = value != 0.0;
  else out = static_cast<T>(value);
}

// The checks a layout passes at compile time: signals inside bytes 0..6 (byte 7 is the CRC), none
// overlapping another carried in the same frame, one rolling counter, at most one multiplexer (one
// bit: multiplexed signals name value 0 or 1), and every integer or enum member wide enough for any
// raw value of its signal.
template <class Layout>
constexpr bool layout_is_consistent(const Layout& layout) {
  bool ok = true;
  int counters = 0, multiplexers = 0;
  layout.for_each_field([&](const auto& f) {
    using T = typename std::remove_cvref_t<decltype(f)>::Value;
    const CanSignal& s = f.signal;
    ok = ok && s.length >= 1 && s.start + s.length <= 56 && s.mux <= 1;
    counters += s.kind == SignalKind::kCounter ? 1 : 0;
    multiplexers += s.kind == SignalKind::kMultiplexer ? 1 : 0;
    if constexpr (std::is_enum_v<T> || std::is_integral_v<T>) {
      using U = typename std::conditional_t<std::is_enum_v<T>, std::underlying_type<T>, std::type_identity<T>>::type;
      ok = ok && !s.is_signed && s.length <= static_cast<unsigned>(std::numeric_limits<U>::digits);
    }
  });
  for (int mux = -1; mux <= 1 && ok; ++mux) {
    std::uint64_t used = 0;
    layout.for_each_field([&](const auto& f) {
      if (!f.signal.carried(mux)) return;
      const std::uint64_t bits = ((std::uint64_t{1} << f.signal.length) - 1u) << f.signal.start;
      ok = ok && (used & bits) == 0u;
      used |= bits;
    });
  }
  return ok && counters == 1 && multiplexers <= 1;
}

}  // namespace v2xloc::protocol
