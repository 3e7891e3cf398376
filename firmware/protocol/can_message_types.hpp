// The CAN messages of v2xloc as physical-value structs, with their identifiers (tools/dbc/v2xloc.dbc;
// firmware/WIRE_FORMATS.md ## CAN). Which signal carries which field is can_message_table.hpp; the
// codec is can_messages.hpp.
#pragma once

#include <cstdint>

namespace v2xloc::protocol {

// ---- Identifiers (lower id wins arbitration: motion first, then GNSS, pose, status) ----------
inline constexpr std::uint32_t kVehicleMotionId = 0x120;
inline constexpr std::uint32_t kGnssPositionId = 0x130;
inline constexpr std::uint32_t kGnssStatusId = 0x131;
inline constexpr std::uint32_t kGnssTimeId = 0x132;
inline constexpr std::uint32_t kGnssVelocityId = 0x133;
inline constexpr std::uint32_t kGnssDopId = 0x134;
inline constexpr std::uint32_t kPosePositionId = 0x200;
inline constexpr std::uint32_t kPoseAttitudeId = 0x201;
inline constexpr std::uint32_t kPoseSigmaId = 0x202;
// Diagnostics out, once per ego frame after the pose frames (evaluation / logging; 0x210-0x21F).
inline constexpr std::uint32_t kRegistrationPositionId = 0x210;
inline constexpr std::uint32_t kRegistrationQualityId = 0x211;
inline constexpr std::uint32_t kGateDecisionId = 0x212;
inline constexpr std::uint32_t kOdometryPositionId = 0x213;
inline constexpr std::uint32_t kOdometryAttitudeId = 0x214;
inline constexpr std::uint32_t kHeartbeatId = 0x300;
// Security diagnostics, 1 Hz after the heartbeat: what the trust layer and the input guards refused.
inline constexpr std::uint32_t kTrustRejectionsId = 0x301;
inline constexpr std::uint32_t kInputGuardsId = 0x302;

inline constexpr std::uint8_t kCounterModulo = 16;  // 4-bit rolling counters

// The CAN layout (tools/dbc/v2xloc.dbc VERSION "v2xloc 2.0"): a recording's CAN log names the one it
// was written in (manifest can_log.layout_version) and the recording reader reads only this one.
inline constexpr int kCanLayoutVersion = 2;

// ---- Vehicle motion (0x120, 10-100 Hz): wheel speed, yaw rate --------------------------------
struct VehicleMotion {
  double wheel_speed_mps = 0.0;  // signed: negative when reversing; [-327.68, 327.67], 0.01 m/s
  double yaw_rate_rps = 0.0;     // [-3.2768, 3.2767], 1e-4 rad/s, counter-clockwise positive
  bool speed_valid = false;
  bool yaw_rate_valid = false;
  std::uint8_t counter = 0;      // 0..15
};

// ---- GNSS, 1-10 Hz: one fix is 0x130 (latitude), 0x130 (longitude), 0x131 status, 0x133 velocity,
// 0x134 DOP, 0x132 time (closes the fix). Every frame carries a rolling counter and a CRC. --------
// 0x130 is multiplexed (PositionMux): 32 bits at 1e-7 deg (cm, what RTK needs) for each of
// latitude and longitude leave no room for a counter and a CRC in one frame, so the latitude goes
// first and the longitude follows with the next counter value (GnssPositionPairer).
enum class GnssPositionHalf : std::uint8_t { kLatitude = 0, kLongitude = 1 };  // PositionMux

struct GnssPosition {
  GnssPositionHalf half = GnssPositionHalf::kLatitude;
  double deg = 0.0;          // latitude [-90, 90] or longitude [-180, 180], 1e-7 deg
  std::uint8_t counter = 0;  // +1 per frame of 0x130: the longitude carries the latitude's + 1
};

enum class GnssFixType : std::uint8_t { kNoFix = 0, kFix2D = 1, kFix3D = 2, kDeadReckoning = 3 };

struct GnssStatus {
  double alt_m = 0.0;        // [-1000, 9485.75], 0.01 m (height above the ellipsoid)
  double h_acc_m = 0.0;      // [0, 204.75], 0.05 m
  double v_acc_m = 0.0;      // [0, 204.75], 0.05 m
  std::uint8_t num_sats = 0; // [0, 63]
  GnssFixType fix_type = GnssFixType::kNoFix;
  std::uint8_t counter = 0;
};

// Doppler velocity of the same fix (0x133, sent before the closing 0x132): what a receiver's
// NAV-PVT-style output carries; its course over ground is a heading while the vehicle moves.
struct GnssVelocity {
  double vel_east_mps = 0.0;   // [-327.68, 327.67], 0.01 m/s
  double vel_north_mps = 0.0;  // [-327.68, 327.67], 0.01 m/s
  double vel_up_mps = 0.0;     // [-10.24, 10.23], 0.01 m/s
  double speed_acc_mps = 0.0;  // [0, 5.1], 0.02 m/s, receiver-reported 1 sigma per axis (saturates)
  bool valid = false;          // the receiver has a velocity solution
  std::uint8_t counter = 0;
};

struct GnssTime {
  double time_of_week_s = 0.0;  // [0, 604799.999], 1 ms
  std::uint16_t week = 0;       // GPS week (full, no rollover)
  std::uint8_t counter = 0;
};

struct GnssDop {
  double hdop = 0.0;  // [0, 25.5], 0.1 (saturates)
  double pdop = 0.0;  // [0, 25.5], 0.1 (saturates)
  std::uint8_t counter = 0;
};

// ---- Fused pose out (0x200..0x202, at the localizer's frame rate) -----------------------------
struct PoseFlags {
  bool pose_valid = false;          // the localizer vouches for this pose
  bool registration_valid = false;  // the latest registration passed the validity gate
  bool gnss_used = false;           // GNSS contributed since the last frame
  bool degraded = false;            // dead reckoning: not localized, or no LiDAR scan this period
};

struct PosePosition {
  double x_m = 0.0;  // local ENU frame, [-8388.608, 8388.607], 1 mm
  double y_m = 0.0;
  PoseFlags flags;
  std::uint8_t counter = 0;
};

struct PoseAttitude {
  double z_m = 0.0;            // [-327.68, 327.67], 0.01 m
  double yaw_rad = 0.0;        // [-3.1416, 3.1416], 1e-4 rad (ENU: 0 = east, CCW positive)
  std::uint16_t frame_counter = 0;  // localizer frame index mod 65536 (ties the three frames)
  PoseFlags flags;
  std::uint8_t counter = 0;
};

struct PoseSigma {
  double sigma_x_m = 0.0;      // [0, 20.475], 0.005 m (1 sigma)
  double sigma_y_m = 0.0;
  double sigma_z_m = 0.0;
  double sigma_yaw_rad = 0.0;  // [0, 0.4095], 1e-4 rad
  std::uint8_t counter = 0;
};

// ---- Diagnostics out (0x210..0x214, once per ego frame, after the pose frames) ----------------
// What the paper's Table 1 needs beyond the fused pose: this frame's registration, the fixed-lag
// gate decision that became available, and the odometry pose. Every value that does not fit its
// signal is clamped and the frame's `clamped` flag is set (in addition to PackStats): a receiver
// never sees a silently wrapped number.
struct RegistrationPosition {
  double x_m = 0.0;             // world (local ENU), [-8388.608, 8388.607], 1 mm
  double y_m = 0.0;
  bool attempted = false;       // a registration ran this frame
  bool ok = false;              // it returned RegistrationStatus::kOk
  bool clamped = false;         // a signal of 0x210 or 0x211 of this frame was saturated
  std::uint8_t counter = 0;
};

struct RegistrationQuality {
  double z_m = 0.0;             // [-32.768, 32.767], 1 mm
  double fitness = 0.0;         // [0, 1.023], 0.001 (inlier fraction)
  double inlier_rmse_m = 0.0;   // [0, 1.023], 1 mm
  std::uint16_t frame_counter = 0;
  std::uint8_t counter = 0;
};

enum class LocalizerModeCode : std::uint8_t { kUninitialized = 0, kGlobalSearch = 1, kTracking = 2 };
inline constexpr std::uint8_t kLocalizerModeMax = 2;

struct GateDecision {
  std::uint16_t decided_frame = 0;  // frame index (mod 65536) the decision is about
  std::uint16_t frame_counter = 0;  // the frame that published it
  bool decided = false;             // a decision became available at this frame
  bool valid = false;               // the decided frame's registration passed the envelope
  LocalizerModeCode mode = LocalizerModeCode::kUninitialized;
  bool filter_initialized = false;  // the fused pose comes from the EKF (else: the GNSS fix)
  std::uint8_t counter = 0;
};

struct OdometryPosition {
  double x_m = 0.0;             // odom frame (LiDAR frame of the first scan), [-8388.608, 8388.607], 1 mm
  double y_m = 0.0;
  bool odometry_ok = false;
  bool clamped = false;         // a signal of 0x213 or 0x214 of this frame was saturated
  std::uint8_t counter = 0;
};

struct OdometryAttitude {
  double z_m = 0.0;             // [-32.768, 32.767], 1 mm
  double yaw_rad = 0.0;         // [-3.1416, 3.1416], 1e-4 rad (wrapped, never clamped)
  std::uint16_t frame_counter = 0;
  bool odometry_ok = false;
  bool clamped = false;
  std::uint8_t counter = 0;
};

// ---- Status / heartbeat (0x300, 1 Hz) --------------------------------------------------------
enum class LocalizerState : std::uint8_t {
  kInit = 0, kWaitingForGnss = 1, kLocalizing = 2, kLocalized = 3, kDegraded = 4, kFault = 5
};
inline constexpr std::uint8_t kLocalizerStateMax = 5;

// Heartbeat ErrorFlags bits (DBC comment of 0x300 ErrorFlags, WIRE_FORMATS.md).
namespace heartbeat_error {
inline constexpr std::uint8_t kCanTimeout = 1u << 0;        // no CAN frame within the input timeout
inline constexpr std::uint8_t kUdpTimeout = 1u << 1;        // no datagram within the input timeout
inline constexpr std::uint8_t kGnssTimeout = 1u << 2;       // no GNSS fix within the GNSS timeout
inline constexpr std::uint8_t kCapacityOverflow = 1u << 3;  // reassembly ran out of capacity
}  // namespace heartbeat_error

struct Heartbeat {
  LocalizerState state = LocalizerState::kInit;
  std::uint8_t error_flags = 0;    // heartbeat_error bits (4 bits)
  double uptime_s = 0.0;           // [0, 1677721.5], 0.1 s
  std::uint8_t can_rx_errors = 0;  // saturating counters since start-up, [0, 255]
  std::uint8_t udp_dropped = 0;
  std::uint8_t counter = 0;
  bool lidar_timeout = false;      // no ego scan with points within the ego-scan timeout (bit 52)
};

// ---- Security diagnostics (0x301, 0x302; 1 Hz, after the heartbeat) ----------------------------
// Saturating counts since start-up of what the firmware refused. 0x301: V2X map shares refused by
// the trust layer, per reason; 0x302: CAN frames refused by CRC/DLC/range or by their rolling
// counter, ego scans refused by the time guard, map shares that arrived unsigned, and signed
// infrastructure clouds map fusion refused as off their unit's surveyed background.
struct TrustRejections {
  std::uint8_t unknown_signer = 0;   // [0, 255] each
  std::uint8_t bad_signature = 0;
  std::uint8_t too_old = 0;
  std::uint8_t future = 0;
  std::uint8_t replay = 0;
  std::uint8_t queue_overflow = 0;   // admitted shares dropped from the full verification queue
  std::uint8_t pose_mismatch = 0;    // [0, 15] infrastructure shares declaring a pose off their survey
  std::uint8_t counter = 0;
};

struct InputGuards {
  std::uint16_t can_crc_rejected = 0;      // [0, 4095] each: DLC / CRC / range failures
  std::uint16_t can_counter_rejected = 0;  // rolling counter repeated (stale or replayed frame)
  std::uint16_t ego_time_rejected = 0;     // ego scans dated implausibly against the local clock
  std::uint16_t missing_signature = 0;     // map shares without a signature
  std::uint8_t background_mismatch = 0;    // [0, 15] infrastructure clouds off their surveyed background
  std::uint8_t counter = 0;
};
inline constexpr std::uint16_t kInputGuardsMax = 4095;

}  // namespace v2xloc::protocol
