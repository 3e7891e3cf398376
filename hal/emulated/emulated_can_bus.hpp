// CAN over a DatagramLink: each datagram carries exactly the 16 bytes of SocketCAN's
// `struct can_frame` (host byte order can_id with EFF/RTR/ERR flags, len, data), decoded by the
// same function as the SocketCAN backend. Filters and the error mask follow CAN_RAW semantics in
// software; receive time stamps come from the given Clock (a SimClock during replay).
// One datagram peer = one point-to-point "bus" (firmware <-> replayer).
#pragma once

#include <array>
#include <cstddef>

#include "hal/can_bus.hpp"
#include "hal/clock.hpp"
#include "hal/datagram_link.hpp"

namespace v2xloc::hal {

class EmulatedCanBus final : public CanBus {
 public:
  EmulatedCanBus(DatagramLink& link, const Clock& clock);

  Status send(const CanFrame& frame) override;
  // Sends raw struct can_frame bytes (error or RTR frames, for tests and the replayer).
  Status send_raw(std::span<const std::uint8_t> can_frame_bytes);
  Status receive(CanRxFrame& out) override;
  Status set_filters(std::span<const CanFilter> filters) override;
  Status accept_all() override;
  Status set_error_mask(std::uint32_t error_classes) override;
  CanCounters counters() const override { return counters_; }

 private:
  DatagramLink& link_;
  const Clock& clock_;
  std::array<CanFilter, kMaxCanFilters> filters_{};
  std::size_t filter_count_ = 0;
  std::uint32_t error_mask_ = 0;
  CanCounters counters_{};
};

}  // namespace v2xloc::hal
