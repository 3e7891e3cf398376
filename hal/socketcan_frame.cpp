#include "hal/socketcan_frame.hpp"

#include <linux/can.h>

#include <cstring>

namespace v2xloc::hal {

static_assert(sizeof(struct can_frame) == kSocketCanFrameBytes && CAN_MTU == kSocketCanFrameBytes);
static_assert(CAN_EFF_FLAG == CanFrame::kExtendedFlag,
              "CanFrame's extended bit is SocketCAN's CAN_EFF_FLAG, so filters map 1:1");

Status encode_socketcan_frame(const CanFrame& frame, std::span<std::uint8_t, kSocketCanFrameBytes> out) {
  if (frame.dlc > CAN_MAX_DLEN) return Status::kInvalidArgument;
  struct can_frame cf;
  std::memset(&cf, 0, sizeof cf);
  const bool extended = (frame.id & CanFrame::kExtendedFlag) != 0;
  if (extended ? (frame.id & ~(CAN_EFF_FLAG | CAN_EFF_MASK)) != 0 : frame.id > CAN_SFF_MASK) {
    return Status::kInvalidArgument;
  }
  cf.can_id = extended ? ((frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : frame.id;
  cf.len = frame.dlc;
  std::memcpy(cf.data, frame.data, frame.dlc);
  std::memcpy(out.data(), &cf, sizeof cf);
  return Status::kOk;
}

std::uint32_t socketcan_raw_id(std::span<const std::uint8_t, kSocketCanFrameBytes> bytes) {
  struct can_frame cf;
  std::memcpy(&cf, bytes.data(), sizeof cf);
  return cf.can_id;
}

Status decode_socketcan_frame(std::span<const std::uint8_t> bytes, CanRxFrame& out) {
  if (bytes.size() != sizeof(struct can_frame)) return Status::kMalformed;
  struct can_frame cf;
  std::memcpy(&cf, bytes.data(), sizeof cf);
  if (cf.len > CAN_MAX_DLEN) return Status::kMalformed;
  out.error = (cf.can_id & CAN_ERR_FLAG) != 0;
  out.remote = !out.error && (cf.can_id & CAN_RTR_FLAG) != 0;
  out.error_class = out.error ? (cf.can_id & CAN_ERR_MASK) : 0u;
  if (out.error) {
    out.frame.id = cf.can_id & CAN_ERR_MASK;
  } else if (cf.can_id & CAN_EFF_FLAG) {
    out.frame.id = (cf.can_id & CAN_EFF_MASK) | CanFrame::kExtendedFlag;
  } else {
    out.frame.id = cf.can_id & CAN_SFF_MASK;
  }
  out.frame.dlc = cf.len;
  std::memset(out.frame.data, 0, sizeof out.frame.data);
  std::memcpy(out.frame.data, cf.data, cf.len);
  return Status::kOk;
}

}  // namespace v2xloc::hal
