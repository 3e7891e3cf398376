// A classic CAN frame as the HAL and the protocol codecs see it. The HAL converts to/from SocketCAN's
// struct can_frame (same fields: 11/29-bit id, 0-8 data bytes).
#pragma once

#include <cstdint>

namespace v2xloc::hal {

struct CanFrame {
  std::uint32_t id = 0;       // 11-bit standard identifier (bit 31 set = 29-bit extended)
  std::uint8_t dlc = 0;       // 0..8
  std::uint8_t data[8] = {};
  static constexpr std::uint32_t kExtendedFlag = 0x80000000u;
};

}  // namespace v2xloc::hal
