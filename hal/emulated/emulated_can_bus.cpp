#include "hal/emulated/emulated_can_bus.hpp"

#include "hal/socketcan_frame.hpp"

namespace v2xloc::hal {
namespace {
constexpr std::uint32_t kErrFlag = 0x20000000u;  // CAN_ERR_FLAG
}

EmulatedCanBus::EmulatedCanBus(DatagramLink& link, const Clock& clock) : link_(link), clock_(clock) {
  accept_all();  // a fresh CAN_RAW socket receives everything too
}

Status EmulatedCanBus::send(const CanFrame& frame) {
  std::array<std::uint8_t, kSocketCanFrameBytes> bytes{};
  const Status encoded = encode_socketcan_frame(frame, bytes);
  if (encoded != Status::kOk) return encoded;
  return send_raw(bytes);
}

Status EmulatedCanBus::send_raw(std::span<const std::uint8_t> bytes) {
  if (bytes.size() != kSocketCanFrameBytes) return Status::kInvalidArgument;
  const Status s = link_.send(bytes);
  if (s == Status::kOk) ++counters_.tx_frames;
  if (s == Status::kWouldBlock) ++counters_.tx_would_block;
  return s;
}

Status EmulatedCanBus::receive(CanRxFrame& out) {
  // Datagrams that a filter rejects are consumed silently, as the kernel does, so one call may
  // read several datagrams; it returns at the first accepted or malformed one.
  std::array<std::uint8_t, 80> buffer{};  // > CANFD_MTU (72), so an FD frame is seen as malformed
  for (;;) {
    DatagramInfo info;
    const Status s = link_.receive(buffer, info);
    if (s == Status::kBufferTooSmall) {
      ++counters_.rx_malformed;
      return Status::kMalformed;
    }
    if (s != Status::kOk) return s;
    const std::span<const std::uint8_t> bytes(buffer.data(), info.size);
    if (decode_socketcan_frame(bytes, out) != Status::kOk) {
      ++counters_.rx_malformed;
      return Status::kMalformed;
    }
    const std::uint32_t raw_id = socketcan_raw_id(std::span<const std::uint8_t, kSocketCanFrameBytes>(buffer.data(), kSocketCanFrameBytes));
    bool accepted = false;
    if (raw_id & kErrFlag) {
      accepted = (out.error_class & error_mask_) != 0;
    } else {
      for (std::size_t i = 0; i < filter_count_ && !accepted; ++i) accepted = can_filter_matches(filters_[i], raw_id);
    }
    if (!accepted) {
      ++counters_.rx_filtered;
      continue;
    }
    out.timestamp_ns = clock_.monotonic_ns();
    if (out.error) {
      ++counters_.rx_errors;
    } else {
      ++counters_.rx_frames;
    }
    return Status::kOk;
  }
}

Status EmulatedCanBus::set_filters(std::span<const CanFilter> filters) {
  if (filters.size() > kMaxCanFilters) return Status::kInvalidArgument;
  for (std::size_t i = 0; i < filters.size(); ++i) filters_[i] = filters[i];
  filter_count_ = filters.size();
  return Status::kOk;
}

Status EmulatedCanBus::accept_all() {
  filters_[0] = CanFilter{0, 0};
  filter_count_ = 1;
  return Status::kOk;
}

Status EmulatedCanBus::set_error_mask(std::uint32_t error_classes) {
  error_mask_ = error_classes & can_error::kAll;
  return Status::kOk;
}

}  // namespace v2xloc::hal
