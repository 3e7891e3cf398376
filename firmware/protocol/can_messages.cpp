#include "firmware/protocol/can_messages.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::protocol {
namespace {

constexpr unsigned kCrcByte = 7;

// Physical -> raw with clamping; NaN becomes the value nearest zero in range. True when clamped.
bool encode_scaled(std::uint8_t* data, const CanSignal& s, double phys) {
  bool saturated = false;
  if (std::isnan(phys)) {  // +-Inf falls into the clamping below
    phys = s.min > 0.0 ? s.min : (s.max < 0.0 ? s.max : 0.0);
    saturated = true;
  }
  if (phys < s.min) {
    phys = s.min;
    saturated = true;
  } else if (phys > s.max) {
    phys = s.max;
    saturated = true;
  }
  const double scaled = (phys - s.offset) / s.factor;
  const auto raw = static_cast<std::int64_t>(std::floor(scaled + 0.5));
  put_bits_le(data, s.start, s.length, static_cast<std::uint64_t>(raw));
  return saturated;
}

// Raw -> physical; flags values outside the DBC range (half an LSB tolerance for rounding).
double decode_scaled(const std::uint8_t* data, const CanSignal& s, bool& out_of_range) {
  const std::uint64_t bits = get_bits_le(data, s.start, s.length);
  std::int64_t raw = static_cast<std::int64_t>(bits);
  if (s.is_signed && s.length < 64 && (bits >> (s.length - 1)) != 0u) {
    raw = static_cast<std::int64_t>(bits) - (static_cast<std::int64_t>(1) << s.length);
  }
  const double phys = static_cast<double>(raw) * s.factor + s.offset;
  const double tol = 0.5 * s.factor;
  if (phys < s.min - tol || phys > s.max + tol) out_of_range = true;
  return phys;
}

}  // namespace

namespace detail {

CanFrame start_frame(std::uint32_t id) {
  CanFrame f;
  f.id = id;
  f.dlc = 8;
  return f;
}

void seal(CanFrame& f) { f.data[kCrcByte] = frame_crc(f.id, f.data); }

DecodeStatus check_frame(const CanFrame& f, std::uint32_t id) {
  if (f.id != id) return DecodeStatus::kWrongId;
  if (f.dlc != 8) return DecodeStatus::kWrongDlc;
  if (f.data[kCrcByte] != frame_crc(f.id, f.data)) return DecodeStatus::kBadChecksum;
  return DecodeStatus::kOk;
}

bool put_signal(std::uint8_t* data, const CanSignal& s, double physical) {
  switch (s.kind) {
    case SignalKind::kScaled: return encode_scaled(data, s, physical);
    // An angle wraps instead of saturating; [-pi, pi] then fits the signal's range.
    case SignalKind::kAngle: return encode_scaled(data, s, std::isfinite(physical) ? det::wrap_pi(physical) : physical);
    case SignalKind::kCounter:
      put_bits_le(data, s.start, s.length, static_cast<std::uint64_t>(physical) % kCounterModulo);
      return false;
    case SignalKind::kMultiplexer:  // the low bits of the selector, as mux_of() reads it
      put_bits_le(data, s.start, s.length, static_cast<std::uint64_t>(physical));
      return false;
    case SignalKind::kFlag:
    case SignalKind::kClampedFlag: put_bits_le(data, s.start, s.length, physical != 0.0 ? 1u : 0u); return false;
  }
  return false;
}

double get_signal(const std::uint8_t* data, const CanSignal& s, bool& out_of_range) {
  if (s.kind == SignalKind::kScaled || s.kind == SignalKind::kAngle) return decode_scaled(data, s, out_of_range);
  return static_cast<double>(get_bits_le(data, s.start, s.length));
}

}  // namespace detail

const char* to_string(DecodeStatus status) {
  switch (status) {
    case DecodeStatus::kOk: return "ok";
    case DecodeStatus::kWrongId: return "wrong id";
    case DecodeStatus::kWrongDlc: return "wrong dlc";
    case DecodeStatus::kBadChecksum: return "bad checksum";
    case DecodeStatus::kOutOfRange: return "out of range";
  }
  return "unknown";
}

void put_bits_le(std::uint8_t* data, unsigned start_bit, unsigned length, std::uint64_t raw) {
  for (unsigned i = 0; i < length; ++i) {
    const unsigned bit = start_bit + i;
    const auto mask = static_cast<std::uint8_t>(1u << (bit % 8u));
    if (((raw >> i) & 1u) != 0u) data[bit / 8u] = static_cast<std::uint8_t>(data[bit / 8u] | mask);
    else data[bit / 8u] = static_cast<std::uint8_t>(data[bit / 8u] & ~mask);
  }
}

std::uint64_t get_bits_le(const std::uint8_t* data, unsigned start_bit, unsigned length) {
  std::uint64_t raw = 0;
  for (unsigned i = 0; i < length; ++i) {
    const unsigned bit = start_bit + i;
    raw |= static_cast<std::uint64_t>((data[bit / 8u] >> (bit % 8u)) & 1u) << i;
  }
  return raw;
}

std::uint8_t crc8_j1850(const std::uint8_t* data, std::uint32_t length, std::uint8_t init) {
  std::uint8_t crc = init;
  for (std::uint32_t i = 0; i < length; ++i) {
    crc = static_cast<std::uint8_t>(crc ^ data[i]);
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 0x80u) != 0u ? static_cast<std::uint8_t>((crc << 1) ^ 0x1Du) : static_cast<std::uint8_t>(crc << 1);
    }
  }
  return static_cast<std::uint8_t>(crc ^ 0xFFu);
}

std::uint8_t frame_crc(std::uint32_t id, const std::uint8_t* data) {
  std::uint8_t buf[9];
  buf[0] = static_cast<std::uint8_t>(id & 0xFFu);
  buf[1] = static_cast<std::uint8_t>((id >> 8) & 0x07u);
  for (int i = 0; i < 7; ++i) buf[2 + i] = data[i];
  return crc8_j1850(buf, 9);
}

// ---- Rolling counters -------------------------------------------------------------------------
bool RollingCounterMonitor::update(std::uint8_t counter) {
  counter = static_cast<std::uint8_t>(counter % kCounterModulo);
  if (!seen_) {
    seen_ = true;
    last_ = counter;
    return true;
  }
  const auto step = static_cast<std::uint8_t>((counter + kCounterModulo - last_) % kCounterModulo);
  last_ = counter;
  if (step == 1) return true;
  if (step == 0) ++repeated_;
  else lost_ += static_cast<std::uint32_t>(step - 1);
  return false;
}

// ---- GNSS position pairing -----------------------------------------------------------------------
GnssPositionPairer::Result GnssPositionPairer::push(const GnssPosition& half) {
  if (half.half == GnssPositionHalf::kLatitude) {
    if (waiting_) ++dropped_;  // the previous latitude's longitude never came
    waiting_ = true;
    lat_counter_ = static_cast<std::uint8_t>(half.counter % kCounterModulo);
    pending_lat_deg_ = half.deg;
    return Result::kWaiting;
  }
  // The longitude of the waiting latitude is the very next frame of this id.
  const bool next = waiting_ && half.counter % kCounterModulo == (lat_counter_ + 1) % kCounterModulo;
  if (!next) {
    dropped_ += waiting_ ? 2u : 1u;
    waiting_ = false;
    return Result::kDropped;
  }
  waiting_ = false;
  lat_deg_ = pending_lat_deg_;
  lon_deg_ = half.deg;
  return Result::kPaired;
}

void GnssPositionPairer::end_fix() {
  if (waiting_) ++dropped_;
  waiting_ = false;
}

}  // namespace v2xloc::protocol
