// SocketCAN backend: raw CAN socket bound to one interface, kernel acceptance filters
// (CAN_RAW_FILTER), kernel receive time stamps (SO_TIMESTAMPNS, falling back to SO_TIMESTAMP),
// error frames (CAN_RAW_ERR_FILTER), optional interface bring-up through libsocketcan.
#pragma once

#include <cstdint>

#include "hal/can_bus.hpp"
#include "hal/linux/error_text.hpp"

namespace v2xloc::hal {

struct SocketCanOptions {
  const char* interface = "can0";
  // Bring-up (needs CAP_NET_ADMIN): stop, set bitrate, start. Not for vcan (no bitrate).
  bool bring_up = false;
  std::uint32_t bitrate = 500'000;
  bool receive_own_messages = false;  // CAN_RAW_RECV_OWN_MSGS
};

class SocketCanBus final : public CanBus {
 public:
  SocketCanBus() = default;
  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  Status open(const SocketCanOptions& options);
  void close();
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }  // for poll()/epoll in a main loop
  const char* last_error() const { return error_.c_str(); }
  bool kernel_timestamps() const { return timestamps_; }

  Status send(const CanFrame& frame) override;
  Status receive(CanRxFrame& out) override;
  Status set_filters(std::span<const CanFilter> filters) override;
  Status accept_all() override;
  Status set_error_mask(std::uint32_t error_classes) override;
  CanCounters counters() const override { return counters_; }

 private:
  int fd_ = -1;
  bool timestamps_ = false;
  CanCounters counters_{};
  linux_backend::ErrorText error_;
};

}  // namespace v2xloc::hal
