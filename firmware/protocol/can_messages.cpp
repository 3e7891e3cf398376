#include "firmware/protocol/can_messages.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::protocol {
namespace {

// One DBC signal: start bit (LSB, Intel), length, signedness, physical = raw * factor + offset,
// physical range [min, max].
struct Signal {
  unsigned start;
  unsigned length;
  bool is_signed;
  double factor;
  double offset;
  double min;
  double max;
};

// ---- Signal table: tools/dbc/v2xloc.dbc is the source of truth; DbcConformance.CodecSignalTableEqualsDbc
// fails on any difference (kSignalTable below lists these constants by DBC name). ----
constexpr Signal kWheelSpeed{0, 16, true, 0.01, 0.0, -327.68, 327.67};
constexpr Signal kYawRate{16, 16, true, 0.0001, 0.0, -3.2768, 3.2767};
// 0x130 is multiplexed: latitude and longitude take the same bits, PositionMux says which.
constexpr Signal kLatitude{0, 32, true, 1e-7, 0.0, -90.0, 90.0};
constexpr Signal kLongitude{0, 32, true, 1e-7, 0.0, -180.0, 180.0};
constexpr unsigned kPositionMuxBit = 32;
constexpr Signal kAltitude{0, 20, false, 0.01, -1000.0, -1000.0, 9485.75};
constexpr Signal kHAcc{20, 12, false, 0.05, 0.0, 0.0, 204.75};
constexpr Signal kVAcc{32, 12, false, 0.05, 0.0, 0.0, 204.75};
constexpr Signal kNumSats{44, 6, false, 1.0, 0.0, 0.0, 63.0};
constexpr Signal kFixType{50, 2, false, 1.0, 0.0, 0.0, 3.0};
constexpr Signal kVelEast{0, 16, true, 0.01, 0.0, -327.68, 327.67};
constexpr Signal kVelNorth{16, 16, true, 0.01, 0.0, -327.68, 327.67};
constexpr Signal kVelUp{32, 11, true, 0.01, 0.0, -10.24, 10.23};
constexpr Signal kSpeedAcc{43, 8, false, 0.02, 0.0, 0.0, 5.1};
constexpr unsigned kVelocityValidBit = 51;
constexpr Signal kGnssStatusCounter{52, 4, false, 1.0, 0.0, 0.0, 15.0};
constexpr Signal kTimeOfWeek{0, 32, false, 0.001, 0.0, 0.0, 604799.999};
constexpr Signal kWeek{32, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr Signal kHdop{0, 8, false, 0.1, 0.0, 0.0, 25.5};
constexpr Signal kPdop{8, 8, false, 0.1, 0.0, 0.0, 25.5};
constexpr Signal kPoseX{0, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kPoseY{24, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kPoseZ{0, 16, true, 0.01, 0.0, -327.68, 327.67};
constexpr Signal kPoseYaw{16, 16, true, 0.0001, 0.0, -3.1416, 3.1416};
constexpr Signal kFrameCounter{32, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr Signal kSigmaX{0, 12, false, 0.005, 0.0, 0.0, 20.475};
constexpr Signal kSigmaY{12, 12, false, 0.005, 0.0, 0.0, 20.475};
constexpr Signal kSigmaZ{24, 12, false, 0.005, 0.0, 0.0, 20.475};
constexpr Signal kSigmaYaw{36, 12, false, 0.0001, 0.0, 0.0, 0.4095};
constexpr Signal kState{0, 4, false, 1.0, 0.0, 0.0, 5.0};
constexpr Signal kErrorFlags{4, 4, false, 1.0, 0.0, 0.0, 15.0};
constexpr Signal kUptime{8, 24, false, 0.1, 0.0, 0.0, 1677721.5};
constexpr Signal kCanRxErrors{32, 8, false, 1.0, 0.0, 0.0, 255.0};
constexpr Signal kUdpDropped{40, 8, false, 1.0, 0.0, 0.0, 255.0};
// Security diagnostics (0x301 counts of 8 bits from bit 0, 0x302 counts of 12 bits from bit 0).
constexpr Signal kTrustCount[6] = {{0, 8, false, 1.0, 0.0, 0.0, 255.0},  {8, 8, false, 1.0, 0.0, 0.0, 255.0},
                                   {16, 8, false, 1.0, 0.0, 0.0, 255.0}, {24, 8, false, 1.0, 0.0, 0.0, 255.0},
                                   {32, 8, false, 1.0, 0.0, 0.0, 255.0}, {40, 8, false, 1.0, 0.0, 0.0, 255.0}};
constexpr Signal kPoseMismatch{52, 4, false, 1.0, 0.0, 0.0, 15.0};  // 0x301 bits 52..55, beside the counter
constexpr Signal kGuardCount[4] = {{0, 12, false, 1.0, 0.0, 0.0, 4095.0},
                                   {12, 12, false, 1.0, 0.0, 0.0, 4095.0},
                                   {24, 12, false, 1.0, 0.0, 0.0, 4095.0},
                                   {36, 12, false, 1.0, 0.0, 0.0, 4095.0}};
constexpr Signal kBackgroundMismatch{52, 4, false, 1.0, 0.0, 0.0, 15.0};  // 0x302 bits 52..55, beside the counter
// Diagnostics (0x210..0x214).
constexpr Signal kRegX{0, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kRegY{24, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kRegZ{0, 16, true, 0.001, 0.0, -32.768, 32.767};
constexpr Signal kRegFitness{16, 10, false, 0.001, 0.0, 0.0, 1.023};
constexpr Signal kRegRmse{26, 10, false, 0.001, 0.0, 0.0, 1.023};
constexpr Signal kRegFrameCounter{36, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr Signal kGateDecidedFrame{0, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr Signal kGateFrameCounter{16, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr Signal kGateMode{34, 2, false, 1.0, 0.0, 0.0, 2.0};
constexpr Signal kOdomX{0, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kOdomY{24, 24, true, 0.001, 0.0, -8388.608, 8388.607};
constexpr Signal kOdomZ{0, 16, true, 0.001, 0.0, -32.768, 32.767};
constexpr Signal kOdomYaw{16, 16, true, 0.0001, 0.0, -3.1416, 3.1416};
constexpr Signal kOdomFrameCounter{32, 16, false, 1.0, 0.0, 0.0, 65535.0};
constexpr unsigned kRegAttemptedBit = 48, kRegOkBit = 49, kRegClampedBit = 50;
constexpr unsigned kGateDecidedBit = 32, kGateValidBit = 33, kGateFilterInitializedBit = 36;
constexpr unsigned kOdomOkBit = 48, kOdomClampedBit = 49;
constexpr unsigned kCounterBit48 = 48;  // VehicleMotion, PoseSigma, Heartbeat, GateDecision
constexpr unsigned kCounterBit52 = 52;  // GNSS frames, Pose/Registration/Odometry frames (flags in 48..51)
constexpr unsigned kFlagsBit = 48;
constexpr unsigned kCrcByte = 7;

// The table above by message and DBC signal name, for the DBC conformance test (can_signal_table).
constexpr NamedCanSignal kSignalTable[] = {
#define V2XLOC_SIGNAL(id, name, s) {id, name, s.start, s.length, s.is_signed, s.factor, s.offset, s.min, s.max}
    V2XLOC_SIGNAL(kVehicleMotionId, "WheelSpeed", kWheelSpeed),
    V2XLOC_SIGNAL(kVehicleMotionId, "YawRate", kYawRate),
    V2XLOC_SIGNAL(kGnssPositionId, "Latitude", kLatitude),
    V2XLOC_SIGNAL(kGnssPositionId, "Longitude", kLongitude),
    V2XLOC_SIGNAL(kGnssStatusId, "Altitude", kAltitude),
    V2XLOC_SIGNAL(kGnssStatusId, "HorizontalAccuracy", kHAcc),
    V2XLOC_SIGNAL(kGnssStatusId, "VerticalAccuracy", kVAcc),
    V2XLOC_SIGNAL(kGnssStatusId, "NumSatellites", kNumSats),
    V2XLOC_SIGNAL(kGnssStatusId, "FixType", kFixType),
    V2XLOC_SIGNAL(kGnssStatusId, "Counter", kGnssStatusCounter),
    V2XLOC_SIGNAL(kGnssVelocityId, "VelEast", kVelEast),
    V2XLOC_SIGNAL(kGnssVelocityId, "VelNorth", kVelNorth),
    V2XLOC_SIGNAL(kGnssVelocityId, "VelUp", kVelUp),
    V2XLOC_SIGNAL(kGnssVelocityId, "SpeedAccuracy", kSpeedAcc),
    V2XLOC_SIGNAL(kGnssTimeId, "TimeOfWeek", kTimeOfWeek),
    V2XLOC_SIGNAL(kGnssTimeId, "Week", kWeek),
    V2XLOC_SIGNAL(kGnssDopId, "Hdop", kHdop),
    V2XLOC_SIGNAL(kGnssDopId, "Pdop", kPdop),
    V2XLOC_SIGNAL(kPosePositionId, "PoseX", kPoseX),
    V2XLOC_SIGNAL(kPosePositionId, "PoseY", kPoseY),
    V2XLOC_SIGNAL(kPoseAttitudeId, "PoseZ", kPoseZ),
    V2XLOC_SIGNAL(kPoseAttitudeId, "PoseYaw", kPoseYaw),
    V2XLOC_SIGNAL(kPoseAttitudeId, "FrameCounter", kFrameCounter),
    V2XLOC_SIGNAL(kPoseSigmaId, "SigmaX", kSigmaX),
    V2XLOC_SIGNAL(kPoseSigmaId, "SigmaY", kSigmaY),
    V2XLOC_SIGNAL(kPoseSigmaId, "SigmaZ", kSigmaZ),
    V2XLOC_SIGNAL(kPoseSigmaId, "SigmaYaw", kSigmaYaw),
    V2XLOC_SIGNAL(kHeartbeatId, "State", kState),
    V2XLOC_SIGNAL(kHeartbeatId, "ErrorFlags", kErrorFlags),
    V2XLOC_SIGNAL(kHeartbeatId, "Uptime", kUptime),
    V2XLOC_SIGNAL(kHeartbeatId, "CanRxErrors", kCanRxErrors),
    V2XLOC_SIGNAL(kHeartbeatId, "UdpDropped", kUdpDropped),
    V2XLOC_SIGNAL(kTrustRejectionsId, "UnknownSigner", kTrustCount[0]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "BadSignature", kTrustCount[1]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "TooOld", kTrustCount[2]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "Future", kTrustCount[3]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "Replay", kTrustCount[4]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "QueueOverflow", kTrustCount[5]),
    V2XLOC_SIGNAL(kTrustRejectionsId, "PoseMismatch", kPoseMismatch),
    V2XLOC_SIGNAL(kInputGuardsId, "CanCrcRejected", kGuardCount[0]),
    V2XLOC_SIGNAL(kInputGuardsId, "CanCounterRejected", kGuardCount[1]),
    V2XLOC_SIGNAL(kInputGuardsId, "EgoTimeRejected", kGuardCount[2]),
    V2XLOC_SIGNAL(kInputGuardsId, "MissingSignature", kGuardCount[3]),
    V2XLOC_SIGNAL(kInputGuardsId, "BackgroundMismatch", kBackgroundMismatch),
    V2XLOC_SIGNAL(kRegistrationPositionId, "RegX", kRegX),
    V2XLOC_SIGNAL(kRegistrationPositionId, "RegY", kRegY),
    V2XLOC_SIGNAL(kRegistrationQualityId, "RegZ", kRegZ),
    V2XLOC_SIGNAL(kRegistrationQualityId, "RegFitness", kRegFitness),
    V2XLOC_SIGNAL(kRegistrationQualityId, "RegRmse", kRegRmse),
    V2XLOC_SIGNAL(kRegistrationQualityId, "FrameCounter", kRegFrameCounter),
    V2XLOC_SIGNAL(kGateDecisionId, "DecidedFrame", kGateDecidedFrame),
    V2XLOC_SIGNAL(kGateDecisionId, "FrameCounter", kGateFrameCounter),
    V2XLOC_SIGNAL(kGateDecisionId, "Mode", kGateMode),
    V2XLOC_SIGNAL(kOdometryPositionId, "OdomX", kOdomX),
    V2XLOC_SIGNAL(kOdometryPositionId, "OdomY", kOdomY),
    V2XLOC_SIGNAL(kOdometryAttitudeId, "OdomZ", kOdomZ),
    V2XLOC_SIGNAL(kOdometryAttitudeId, "OdomYaw", kOdomYaw),
    V2XLOC_SIGNAL(kOdometryAttitudeId, "FrameCounter", kOdomFrameCounter),
#undef V2XLOC_SIGNAL
};

// Physical -> raw with clamping; NaN becomes the value nearest zero in range. Counts saturation.
void encode(std::uint8_t* data, const Signal& s, double phys, PackStats* stats) {
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
  if (saturated && stats != nullptr) ++stats->saturated;
  const double scaled = (phys - s.offset) / s.factor;
  const auto raw = static_cast<std::int64_t>(std::floor(scaled + 0.5));
  put_bits_le(data, s.start, s.length, static_cast<std::uint64_t>(raw));
}

// Raw -> physical; flags values outside the DBC range (half an LSB tolerance for rounding).
double decode(const std::uint8_t* data, const Signal& s, bool& out_of_range) {
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

void put_flag(std::uint8_t* data, unsigned bit, bool value) { put_bits_le(data, bit, 1, value ? 1u : 0u); }
bool get_flag(const std::uint8_t* data, unsigned bit) { return get_bits_le(data, bit, 1) != 0u; }

// Packs with a local count so the frame's own clamped flag can be set; forwards the count.
struct SaturationScope {
  PackStats local;
  PackStats* outer;
  explicit SaturationScope(PackStats* o) : outer(o) {}
  bool any() const { return local.saturated != 0u; }
  ~SaturationScope() {
    if (outer != nullptr) outer->saturated += local.saturated;
  }
};

void put_counter(std::uint8_t* data, unsigned bit, std::uint8_t counter) {
  put_bits_le(data, bit, 4, counter % kCounterModulo);
}

std::uint8_t pack_flags(const PoseFlags& f) {
  return static_cast<std::uint8_t>((f.pose_valid ? 1u : 0u) | (f.registration_valid ? 2u : 0u) |
                                   (f.gnss_used ? 4u : 0u) | (f.degraded ? 8u : 0u));
}
PoseFlags unpack_flags(std::uint8_t bits) {
  PoseFlags f;
  f.pose_valid = (bits & 1u) != 0u;
  f.registration_valid = (bits & 2u) != 0u;
  f.gnss_used = (bits & 4u) != 0u;
  f.degraded = (bits & 8u) != 0u;
  return f;
}

CanFrame start_frame(std::uint32_t id) {
  CanFrame f;
  f.id = id;
  f.dlc = 8;
  return f;
}
void seal(CanFrame& f) { f.data[kCrcByte] = frame_crc(f.id, f.data); }

// Every message carries the CRC (layout 2 gave the GNSS position and time frames theirs).
DecodeStatus check(const CanFrame& f, std::uint32_t id) {
  if (f.id != id) return DecodeStatus::kWrongId;
  if (f.dlc != 8) return DecodeStatus::kWrongDlc;
  if (f.data[kCrcByte] != frame_crc(f.id, f.data)) return DecodeStatus::kBadChecksum;
  return DecodeStatus::kOk;
}

DecodeStatus range_status(bool out_of_range) {
  return out_of_range ? DecodeStatus::kOutOfRange : DecodeStatus::kOk;
}

}  // namespace

std::span<const NamedCanSignal> can_signal_table() { return kSignalTable; }

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

// ---- Vehicle motion ---------------------------------------------------------------------------
CanFrame pack(const VehicleMotion& m, PackStats* stats) {
  CanFrame f = start_frame(kVehicleMotionId);
  encode(f.data, kWheelSpeed, m.wheel_speed_mps, stats);
  encode(f.data, kYawRate, m.yaw_rate_rps, stats);
  put_bits_le(f.data, 32, 1, m.speed_valid ? 1u : 0u);
  put_bits_le(f.data, 33, 1, m.yaw_rate_valid ? 1u : 0u);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, VehicleMotion& m) {
  const DecodeStatus s = check(f, kVehicleMotionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.wheel_speed_mps = decode(f.data, kWheelSpeed, oor);
  m.yaw_rate_rps = decode(f.data, kYawRate, oor);
  m.speed_valid = get_bits_le(f.data, 32, 1) != 0u;
  m.yaw_rate_valid = get_bits_le(f.data, 33, 1) != 0u;
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return range_status(oor);
}

// ---- GNSS -------------------------------------------------------------------------------------
CanFrame pack(const GnssPosition& m, PackStats* stats) {
  CanFrame f = start_frame(kGnssPositionId);
  const bool lon = m.half == GnssPositionHalf::kLongitude;
  encode(f.data, lon ? kLongitude : kLatitude, m.deg, stats);
  put_flag(f.data, kPositionMuxBit, lon);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GnssPosition& m) {
  const DecodeStatus s = check(f, kGnssPositionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  const bool lon = get_flag(f.data, kPositionMuxBit);
  m.half = lon ? GnssPositionHalf::kLongitude : GnssPositionHalf::kLatitude;
  m.deg = decode(f.data, lon ? kLongitude : kLatitude, oor);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const GnssStatus& m, PackStats* stats) {
  CanFrame f = start_frame(kGnssStatusId);
  encode(f.data, kAltitude, m.alt_m, stats);
  encode(f.data, kHAcc, m.h_acc_m, stats);
  encode(f.data, kVAcc, m.v_acc_m, stats);
  encode(f.data, kNumSats, static_cast<double>(m.num_sats), stats);
  encode(f.data, kFixType, static_cast<double>(static_cast<std::uint8_t>(m.fix_type)), stats);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GnssStatus& m) {
  const DecodeStatus s = check(f, kGnssStatusId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.alt_m = decode(f.data, kAltitude, oor);
  m.h_acc_m = decode(f.data, kHAcc, oor);
  m.v_acc_m = decode(f.data, kVAcc, oor);
  m.num_sats = static_cast<std::uint8_t>(decode(f.data, kNumSats, oor));
  m.fix_type = static_cast<GnssFixType>(get_bits_le(f.data, kFixType.start, kFixType.length));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kGnssStatusCounter.start, 4));
  return range_status(oor);
}

CanFrame pack(const GnssVelocity& m, PackStats* stats) {
  CanFrame f = start_frame(kGnssVelocityId);
  encode(f.data, kVelEast, m.vel_east_mps, stats);
  encode(f.data, kVelNorth, m.vel_north_mps, stats);
  encode(f.data, kVelUp, m.vel_up_mps, stats);
  encode(f.data, kSpeedAcc, m.speed_acc_mps, stats);
  put_flag(f.data, kVelocityValidBit, m.valid);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GnssVelocity& m) {
  const DecodeStatus s = check(f, kGnssVelocityId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.vel_east_mps = decode(f.data, kVelEast, oor);
  m.vel_north_mps = decode(f.data, kVelNorth, oor);
  m.vel_up_mps = decode(f.data, kVelUp, oor);
  m.speed_acc_mps = decode(f.data, kSpeedAcc, oor);
  m.valid = get_flag(f.data, kVelocityValidBit);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const GnssTime& m, PackStats* stats) {
  CanFrame f = start_frame(kGnssTimeId);
  encode(f.data, kTimeOfWeek, m.time_of_week_s, stats);
  encode(f.data, kWeek, static_cast<double>(m.week), stats);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GnssTime& m) {
  const DecodeStatus s = check(f, kGnssTimeId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.time_of_week_s = decode(f.data, kTimeOfWeek, oor);
  m.week = static_cast<std::uint16_t>(get_bits_le(f.data, kWeek.start, kWeek.length));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const GnssDop& m, PackStats* stats) {
  CanFrame f = start_frame(kGnssDopId);
  encode(f.data, kHdop, m.hdop, stats);
  encode(f.data, kPdop, m.pdop, stats);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GnssDop& m) {
  const DecodeStatus s = check(f, kGnssDopId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.hdop = decode(f.data, kHdop, oor);
  m.pdop = decode(f.data, kPdop, oor);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

// ---- Fused pose out ---------------------------------------------------------------------------
CanFrame pack(const PosePosition& m, PackStats* stats) {
  CanFrame f = start_frame(kPosePositionId);
  encode(f.data, kPoseX, m.x_m, stats);
  encode(f.data, kPoseY, m.y_m, stats);
  put_bits_le(f.data, kFlagsBit, 4, pack_flags(m.flags));
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, PosePosition& m) {
  const DecodeStatus s = check(f, kPosePositionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.x_m = decode(f.data, kPoseX, oor);
  m.y_m = decode(f.data, kPoseY, oor);
  m.flags = unpack_flags(static_cast<std::uint8_t>(get_bits_le(f.data, kFlagsBit, 4)));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const PoseAttitude& m, PackStats* stats) {
  CanFrame f = start_frame(kPoseAttitudeId);
  encode(f.data, kPoseZ, m.z_m, stats);
  // An angle wraps instead of saturating; [-pi, pi] then fits the signal's range.
  encode(f.data, kPoseYaw, std::isfinite(m.yaw_rad) ? det::wrap_pi(m.yaw_rad) : m.yaw_rad, stats);
  encode(f.data, kFrameCounter, static_cast<double>(m.frame_counter), stats);
  put_bits_le(f.data, kFlagsBit, 4, pack_flags(m.flags));
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, PoseAttitude& m) {
  const DecodeStatus s = check(f, kPoseAttitudeId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.z_m = decode(f.data, kPoseZ, oor);
  m.yaw_rad = decode(f.data, kPoseYaw, oor);
  m.frame_counter = static_cast<std::uint16_t>(get_bits_le(f.data, kFrameCounter.start, kFrameCounter.length));
  m.flags = unpack_flags(static_cast<std::uint8_t>(get_bits_le(f.data, kFlagsBit, 4)));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const PoseSigma& m, PackStats* stats) {
  CanFrame f = start_frame(kPoseSigmaId);
  encode(f.data, kSigmaX, m.sigma_x_m, stats);
  encode(f.data, kSigmaY, m.sigma_y_m, stats);
  encode(f.data, kSigmaZ, m.sigma_z_m, stats);
  encode(f.data, kSigmaYaw, m.sigma_yaw_rad, stats);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, PoseSigma& m) {
  const DecodeStatus s = check(f, kPoseSigmaId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.sigma_x_m = decode(f.data, kSigmaX, oor);
  m.sigma_y_m = decode(f.data, kSigmaY, oor);
  m.sigma_z_m = decode(f.data, kSigmaZ, oor);
  m.sigma_yaw_rad = decode(f.data, kSigmaYaw, oor);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return range_status(oor);
}

// ---- Heartbeat --------------------------------------------------------------------------------
CanFrame pack(const Heartbeat& m, PackStats* stats) {
  CanFrame f = start_frame(kHeartbeatId);
  encode(f.data, kState, static_cast<double>(static_cast<std::uint8_t>(m.state)), stats);
  encode(f.data, kErrorFlags, static_cast<double>(m.error_flags), stats);
  encode(f.data, kUptime, m.uptime_s, stats);
  encode(f.data, kCanRxErrors, static_cast<double>(m.can_rx_errors), stats);
  encode(f.data, kUdpDropped, static_cast<double>(m.udp_dropped), stats);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, Heartbeat& m) {
  const DecodeStatus s = check(f, kHeartbeatId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  const auto state = static_cast<std::uint8_t>(decode(f.data, kState, oor));
  m.state = static_cast<LocalizerState>(state);
  m.error_flags = static_cast<std::uint8_t>(get_bits_le(f.data, kErrorFlags.start, kErrorFlags.length));
  m.uptime_s = decode(f.data, kUptime, oor);
  m.can_rx_errors = static_cast<std::uint8_t>(get_bits_le(f.data, kCanRxErrors.start, 8));
  m.udp_dropped = static_cast<std::uint8_t>(get_bits_le(f.data, kUdpDropped.start, 8));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return range_status(oor);
}

// ---- Security diagnostics ---------------------------------------------------------------------
CanFrame pack(const TrustRejections& m, PackStats* stats) {
  CanFrame f = start_frame(kTrustRejectionsId);
  const std::uint8_t counts[6] = {m.unknown_signer, m.bad_signature, m.too_old, m.future, m.replay, m.queue_overflow};
  for (int k = 0; k < 6; ++k) encode(f.data, kTrustCount[k], static_cast<double>(counts[k]), stats);
  encode(f.data, kPoseMismatch, static_cast<double>(m.pose_mismatch), stats);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, TrustRejections& m) {
  const DecodeStatus s = check(f, kTrustRejectionsId);
  if (s != DecodeStatus::kOk) return s;
  std::uint8_t* counts[6] = {&m.unknown_signer, &m.bad_signature, &m.too_old, &m.future, &m.replay, &m.queue_overflow};
  for (int k = 0; k < 6; ++k) *counts[k] = static_cast<std::uint8_t>(get_bits_le(f.data, kTrustCount[k].start, 8));
  m.pose_mismatch = static_cast<std::uint8_t>(get_bits_le(f.data, kPoseMismatch.start, kPoseMismatch.length));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return DecodeStatus::kOk;
}

CanFrame pack(const InputGuards& m, PackStats* stats) {
  CanFrame f = start_frame(kInputGuardsId);
  const std::uint16_t counts[4] = {m.can_crc_rejected, m.can_counter_rejected, m.ego_time_rejected, m.missing_signature};
  for (int k = 0; k < 4; ++k) encode(f.data, kGuardCount[k], static_cast<double>(counts[k]), stats);
  encode(f.data, kBackgroundMismatch, static_cast<double>(m.background_mismatch), stats);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, InputGuards& m) {
  const DecodeStatus s = check(f, kInputGuardsId);
  if (s != DecodeStatus::kOk) return s;
  std::uint16_t* counts[4] = {&m.can_crc_rejected, &m.can_counter_rejected, &m.ego_time_rejected, &m.missing_signature};
  for (int k = 0; k < 4; ++k) *counts[k] = static_cast<std::uint16_t>(get_bits_le(f.data, kGuardCount[k].start, 12));
  m.background_mismatch =
      static_cast<std::uint8_t>(get_bits_le(f.data, kBackgroundMismatch.start, kBackgroundMismatch.length));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return DecodeStatus::kOk;
}

// ---- Diagnostics ------------------------------------------------------------------------------
CanFrame pack(const RegistrationPosition& m, PackStats* stats) {
  CanFrame f = start_frame(kRegistrationPositionId);
  SaturationScope sat(stats);
  encode(f.data, kRegX, m.x_m, &sat.local);
  encode(f.data, kRegY, m.y_m, &sat.local);
  put_flag(f.data, kRegAttemptedBit, m.attempted);
  put_flag(f.data, kRegOkBit, m.ok);
  put_flag(f.data, kRegClampedBit, m.clamped || sat.any());
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, RegistrationPosition& m) {
  const DecodeStatus s = check(f, kRegistrationPositionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.x_m = decode(f.data, kRegX, oor);
  m.y_m = decode(f.data, kRegY, oor);
  m.attempted = get_flag(f.data, kRegAttemptedBit);
  m.ok = get_flag(f.data, kRegOkBit);
  m.clamped = get_flag(f.data, kRegClampedBit);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const RegistrationQuality& m, PackStats* stats) {
  CanFrame f = start_frame(kRegistrationQualityId);
  encode(f.data, kRegZ, m.z_m, stats);
  encode(f.data, kRegFitness, m.fitness, stats);
  encode(f.data, kRegRmse, m.inlier_rmse_m, stats);
  encode(f.data, kRegFrameCounter, static_cast<double>(m.frame_counter), stats);
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, RegistrationQuality& m) {
  const DecodeStatus s = check(f, kRegistrationQualityId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.z_m = decode(f.data, kRegZ, oor);
  m.fitness = decode(f.data, kRegFitness, oor);
  m.inlier_rmse_m = decode(f.data, kRegRmse, oor);
  m.frame_counter = static_cast<std::uint16_t>(get_bits_le(f.data, kRegFrameCounter.start, kRegFrameCounter.length));
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const GateDecision& m, PackStats* stats) {
  CanFrame f = start_frame(kGateDecisionId);
  encode(f.data, kGateDecidedFrame, static_cast<double>(m.decided_frame), stats);
  encode(f.data, kGateFrameCounter, static_cast<double>(m.frame_counter), stats);
  put_flag(f.data, kGateDecidedBit, m.decided);
  put_flag(f.data, kGateValidBit, m.valid);
  encode(f.data, kGateMode, static_cast<double>(static_cast<std::uint8_t>(m.mode)), stats);
  put_flag(f.data, kGateFilterInitializedBit, m.filter_initialized);
  put_counter(f.data, kCounterBit48, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, GateDecision& m) {
  const DecodeStatus s = check(f, kGateDecisionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.decided_frame = static_cast<std::uint16_t>(get_bits_le(f.data, kGateDecidedFrame.start, kGateDecidedFrame.length));
  m.frame_counter = static_cast<std::uint16_t>(get_bits_le(f.data, kGateFrameCounter.start, kGateFrameCounter.length));
  m.decided = get_flag(f.data, kGateDecidedBit);
  m.valid = get_flag(f.data, kGateValidBit);
  m.mode = static_cast<LocalizerModeCode>(static_cast<std::uint8_t>(decode(f.data, kGateMode, oor)));
  m.filter_initialized = get_flag(f.data, kGateFilterInitializedBit);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit48, 4));
  return range_status(oor);
}

CanFrame pack(const OdometryPosition& m, PackStats* stats) {
  CanFrame f = start_frame(kOdometryPositionId);
  SaturationScope sat(stats);
  encode(f.data, kOdomX, m.x_m, &sat.local);
  encode(f.data, kOdomY, m.y_m, &sat.local);
  put_flag(f.data, kOdomOkBit, m.odometry_ok);
  put_flag(f.data, kOdomClampedBit, m.clamped || sat.any());
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, OdometryPosition& m) {
  const DecodeStatus s = check(f, kOdometryPositionId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.x_m = decode(f.data, kOdomX, oor);
  m.y_m = decode(f.data, kOdomY, oor);
  m.odometry_ok = get_flag(f.data, kOdomOkBit);
  m.clamped = get_flag(f.data, kOdomClampedBit);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
}

CanFrame pack(const OdometryAttitude& m, PackStats* stats) {
  CanFrame f = start_frame(kOdometryAttitudeId);
  SaturationScope sat(stats);
  encode(f.data, kOdomZ, m.z_m, &sat.local);
  // An angle wraps instead of saturating (as PoseYaw).
  encode(f.data, kOdomYaw, std::isfinite(m.yaw_rad) ? det::wrap_pi(m.yaw_rad) : m.yaw_rad, &sat.local);
  encode(f.data, kOdomFrameCounter, static_cast<double>(m.frame_counter), &sat.local);
  put_flag(f.data, kOdomOkBit, m.odometry_ok);
  put_flag(f.data, kOdomClampedBit, m.clamped || sat.any());
  put_counter(f.data, kCounterBit52, m.counter);
  seal(f);
  return f;
}

DecodeStatus unpack(const CanFrame& f, OdometryAttitude& m) {
  const DecodeStatus s = check(f, kOdometryAttitudeId);
  if (s != DecodeStatus::kOk) return s;
  bool oor = false;
  m.z_m = decode(f.data, kOdomZ, oor);
  m.yaw_rad = decode(f.data, kOdomYaw, oor);
  m.frame_counter = static_cast<std::uint16_t>(get_bits_le(f.data, kOdomFrameCounter.start, kOdomFrameCounter.length));
  m.odometry_ok = get_flag(f.data, kOdomOkBit);
  m.clamped = get_flag(f.data, kOdomClampedBit);
  m.counter = static_cast<std::uint8_t>(get_bits_le(f.data, kCounterBit52, 4));
  return range_status(oor);
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
