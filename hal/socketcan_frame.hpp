// The one place that converts between CanFrame and SocketCAN's `struct can_frame`
// (16 bytes, <linux/can.h>). Both the SocketCAN backend (bytes from read()) and the emulated
// CAN-over-UDP backend (bytes from a datagram) decode through decode_socketcan_frame(), so the
// emulated path is the real path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/can_bus.hpp"

namespace v2xloc::hal {

inline constexpr std::size_t kSocketCanFrameBytes = 16;  // == CAN_MTU (static_assert in the .cpp)

// Writes the 16 bytes of a struct can_frame (host byte order can_id, as the kernel uses).
Status encode_socketcan_frame(const CanFrame& frame, std::span<std::uint8_t, kSocketCanFrameBytes> out);

// kMalformed unless exactly 16 bytes with len <= 8. Sets remote / error / error_class; leaves
// timestamp_ns untouched.
Status decode_socketcan_frame(std::span<const std::uint8_t> bytes, CanRxFrame& out);

// Raw kernel can_id (with EFF/RTR/ERR flag bits) of encoded bytes, for filtering.
std::uint32_t socketcan_raw_id(std::span<const std::uint8_t, kSocketCanFrameBytes> bytes);

}  // namespace v2xloc::hal
