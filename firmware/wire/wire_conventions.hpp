// Conventions shared by the firmware, the replayer and the offline evaluator, so that the same
// wire bytes always decode to the same localizer inputs (firmware/README.md, "Conventions").
#pragma once

#include <cstddef>
#include <cstdint>

#include "hal/can_frame.hpp"
#include "hal/little_endian.hpp"

namespace v2xloc::firmware {

// ---- Point-cloud sender ids: stable per sensor; the range tells infrastructure from vehicles. --
inline constexpr std::uint32_t kEgoSenderId = 0;          // the ego vehicle's own LiDAR
inline constexpr std::uint32_t kInfraSenderBase = 1;      // infrastructure unit k -> 1 + k
inline constexpr std::uint32_t kAgentSenderBase = 32;     // agent vehicle k -> 32 + k
inline constexpr bool sender_is_agent(std::uint32_t sender_id) { return sender_id >= kAgentSenderBase; }

// Quantization of every cloud on the wire: int16 at 4 mm covers +-131 m (the LiDARs' 100 m
// range) with <= 2 mm error per axis, far below the 2 cm range noise, at 6 bytes per point.
inline constexpr float kCloudScaleM = 0.004f;

// ---- Time -------------------------------------------------------------------------------------
// Localizer time [s] = (disciplined time ns - epoch ns) * 1e-9. Every path (firmware, offline)
// converts integer nanoseconds with this one function, so equal stamps give equal bits.
inline double localizer_time_s(std::int64_t time_ns, std::int64_t epoch_ns) {
  return static_cast<double>(time_ns - epoch_ns) * 1e-9;
}

// ---- Emulation only: simulated time on the emulated CAN link ------------------------------------
// The replayer drives the firmware's SimClock with this extended-id frame (8 data bytes: int64
// monotonic ns, little-endian) sent before the data of that instant; the emulated backend wiring
// in main consumes it, the application never sees it. A real bus never carries it.
inline constexpr std::uint32_t kSimTimeCanId = hal::CanFrame::kExtendedFlag | 0x1FFFFF00u;

inline hal::CanFrame make_sim_time_frame(std::int64_t monotonic_ns) {
  hal::CanFrame f;
  f.id = kSimTimeCanId;
  f.dlc = 8;
  hal::le::put_u64(f.data, static_cast<std::uint64_t>(monotonic_ns));
  return f;
}

inline bool parse_sim_time_frame(const hal::CanFrame& f, std::int64_t& monotonic_ns) {
  if (f.id != kSimTimeCanId || f.dlc != 8) return false;
  monotonic_ns = static_cast<std::int64_t>(hal::le::get_u64(f.data));
  return true;
}

}  // namespace v2xloc::firmware
