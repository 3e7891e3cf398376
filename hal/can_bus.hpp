// Classic CAN bus: send/receive CanFrame, acceptance filters, receive time stamps,
// error frames. Non-blocking: receive() returns kWouldBlock when the queue is empty.
#pragma once

#include <cstdint>
#include <span>

#include "hal/can_frame.hpp"
#include "hal/status.hpp"

namespace v2xloc::hal {

// Accept a frame when (frame_id & mask) == (id & mask), SocketCAN CAN_RAW_FILTER semantics:
// `id` and `mask` use the CanFrame id encoding (bit 31 = extended), and a mask with bit 31 set
// also requires the frame format (standard/extended) to match.
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  static constexpr std::uint32_t kStandardMask = 0x7FFu | CanFrame::kExtendedFlag;
  static constexpr std::uint32_t kExtendedMask = 0x1FFFFFFFu | CanFrame::kExtendedFlag;
};
inline constexpr std::size_t kMaxCanFilters = 32;

// Error classes (SocketCAN CAN_ERR_* bits of the error frame's id, <linux/can/error.h>).
namespace can_error {
inline constexpr std::uint32_t kTxTimeout = 0x001;
inline constexpr std::uint32_t kLostArbitration = 0x002;
inline constexpr std::uint32_t kController = 0x004;  // data[1]: CAN_ERR_CRTL_* (passive, warning)
inline constexpr std::uint32_t kProtocol = 0x008;
inline constexpr std::uint32_t kTransceiver = 0x010;
inline constexpr std::uint32_t kNoAck = 0x020;
inline constexpr std::uint32_t kBusOff = 0x040;
inline constexpr std::uint32_t kBusError = 0x080;
inline constexpr std::uint32_t kRestarted = 0x100;
inline constexpr std::uint32_t kAll = 0x1FFFFFFFu;
}  // namespace can_error

struct CanRxFrame {
  CanFrame frame;        // for error frames: data holds the error details
  std::int64_t timestamp_ns = 0;   // receive time on the CLOCK_MONOTONIC / Clock::monotonic_ns base
  bool remote = false;             // RTR frame (no data)
  bool error = false;              // error frame; error_class holds the can_error bits
  std::uint32_t error_class = 0;
};

struct CanCounters {
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_errors = 0;      // error frames delivered
  std::uint64_t rx_malformed = 0;   // wrong-size datagrams / frames dropped
  std::uint64_t rx_filtered = 0;    // dropped by a software filter (emulated backend)
  std::uint64_t tx_would_block = 0;
};

class CanBus {
 public:
  virtual ~CanBus() = default;
  virtual Status send(const CanFrame& frame) = 0;
  virtual Status receive(CanRxFrame& out) = 0;
  // Replaces all filters; an empty span accepts nothing, use accept_all() to receive everything.
  virtual Status set_filters(std::span<const CanFilter> filters) = 0;
  virtual Status accept_all() = 0;
  // Which error classes are delivered as error frames (0 = none, the default).
  virtual Status set_error_mask(std::uint32_t error_classes) = 0;
  virtual CanCounters counters() const = 0;
};

// True when `frame_id` (CanFrame encoding) passes `filter` (shared by software filtering).
bool can_filter_matches(const CanFilter& filter, std::uint32_t frame_id);

}  // namespace v2xloc::hal
