// Vehicle-bus CAN frames -> localizer inputs: 0x120 vehicle motion, and the GNSS fix assembled from
// 0x130 position halves, 0x131 status, 0x133 velocity and 0x134 DOP, closed by the 0x132 time frame
// (GnssFixAssembler). Every frame goes through the DBC codec (firmware/protocol/can_messages.hpp:
// DLC, CRC, range) and its message's rolling counter; what fails is counted, never forwarded.
// Returns typed inputs and never calls the localizer. Allocation-free.
#pragma once

#include <cstdint>

#include "firmware/protocol/can_messages.hpp"
#include "firmware/wire/gnss_fix_assembler.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::firmware {

enum class CanInputKind : std::uint8_t {
  kVehicle,       // decoded a VehicleInput
  kGnssFix,       // decoded a GnssInput (on the time frame that closes a fix)
  kGnssPart,      // position half, status, velocity or DOP of a fix, stored until the time frame
  kInvalid,       // decoded, but flagged invalid by the sender, or a position half that pairs with
                  // nothing, or a time frame closing a fix without status (counted, not forwarded)
  kRejected,      // wrong DLC, CRC or range, or a repeated rolling counter (counted)
  kUnknownId,     // not ours (counted)
};

// One decoded CAN frame: `vehicle` is set for kVehicle, `gnss` for kGnssFix.
struct DecodedCan {
  CanInputKind kind = CanInputKind::kUnknownId;
  VehicleInput vehicle{};
  GnssInput gnss{};
};

struct CanCounters {
  std::uint64_t can_frames = 0;
  std::uint64_t vehicle_inputs = 0;
  std::uint64_t vehicle_invalid = 0;
  std::uint64_t gnss_inputs = 0;
  std::uint64_t gnss_incomplete = 0;        // time frame without the fix's status frame
  std::uint64_t gnss_position_dropped = 0;  // 0x130 halves that formed no position (GnssPositionPairer)
  std::uint64_t can_rejected = 0;           // DLC / CRC / range failures
  std::uint64_t can_unknown_id = 0;
  std::uint64_t can_repeated = 0;           // rolling counter did not advance: replayed / stuck frame, dropped
  std::uint64_t can_counter_gaps = 0;       // frames lost by the rolling counter (accepted, counted)
};

class CanInputDecoder {
 public:
  // epoch_ns: disciplined time that maps to localizer time 0 (see localizer_time_s).
  explicit CanInputDecoder(std::int64_t epoch_ns = 0) : epoch_ns_(epoch_ns) {}
  void set_epoch_ns(std::int64_t epoch_ns) { epoch_ns_ = epoch_ns; }

  // One CAN frame received at disciplined time time_ns.
  DecodedCan decode(const hal::CanFrame& frame, std::int64_t time_ns);
  // Latest GNSS time frame (valid after kGnssFix), for PPS discipline.
  const protocol::GnssTime& last_gnss_time() const { return gnss_time_; }
  // True when a GNSS fix was decoded since the previous call (the pose flag GnssUsed of the next
  // ego scan); clears it.
  bool take_gnss_fix_seen() {
    const bool seen = gnss_fix_seen_;
    gnss_fix_seen_ = false;
    return seen;
  }

  const CanCounters& counters() const { return counters_; }

 private:
  static DecodedCan with_kind(CanInputKind kind);
  // CRC / DLC / range, then the rolling counter; only an accepted frame reaches `out` (counted).
  template <typename M>
  bool accept(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor, M& out);
  // Rolling counters (every inbound frame carries one): a repeat is dropped, a gap counted.
  bool counter_ok(protocol::RollingCounterMonitor& monitor, std::uint8_t counter);
  DecodedCan decode_vehicle(const hal::CanFrame& frame, double t);
  DecodedCan decode_position(const hal::CanFrame& frame);
  // Status, velocity or DOP: stored in the fix by `store` (a GnssFixAssembler setter).
  template <typename M>
  DecodedCan decode_gnss_part(const hal::CanFrame& frame, protocol::RollingCounterMonitor& monitor,
                              void (GnssFixAssembler::*store)(const M&));
  DecodedCan decode_time(const hal::CanFrame& frame, double t);
  // Adds the pairer's newly dropped halves (since `before`) to the counters.
  void count_positions_dropped(std::uint32_t before);

  std::int64_t epoch_ns_ = 0;
  protocol::RollingCounterMonitor vehicle_counter_{};
  protocol::RollingCounterMonitor gnss_position_counter_{};
  protocol::RollingCounterMonitor gnss_status_counter_{};
  protocol::RollingCounterMonitor gnss_velocity_counter_{};
  protocol::RollingCounterMonitor gnss_dop_counter_{};
  protocol::RollingCounterMonitor gnss_time_counter_{};
  GnssFixAssembler fix_{};
  protocol::GnssTime gnss_time_{};
  bool gnss_fix_seen_ = false;  // a GNSS fix was decoded since take_gnss_fix_seen()
  CanCounters counters_{};
};

}  // namespace v2xloc::firmware
