#include "hal/linux/socketcan_bus.hpp"

#include <fcntl.h>
#include <libsocketcan.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "hal/linux/linux_clock.hpp"
#include "hal/socketcan_frame.hpp"

namespace v2xloc::hal {

SocketCanBus::~SocketCanBus() { close(); }

void SocketCanBus::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Status SocketCanBus::open(const SocketCanOptions& options) {
  close();
  error_.clear();
  if (options.interface == nullptr || std::strlen(options.interface) >= IFNAMSIZ) {
    error_.set("interface name missing or too long");
    return Status::kInvalidArgument;
  }
  if (options.bring_up) {
    // libsocketcan talks rtnetlink; each step fails without CAP_NET_ADMIN or on vcan.
    char what[96];
    if (can_do_stop(options.interface) != 0) {
      std::snprintf(what, sizeof what, "can_do_stop(%s)", options.interface);
      return error_.set_errno(what, errno != 0 ? errno : EIO);
    }
    if (can_set_bitrate(options.interface, options.bitrate) != 0) {
      std::snprintf(what, sizeof what, "can_set_bitrate(%s, %u)", options.interface, options.bitrate);
      return error_.set_errno(what, errno != 0 ? errno : EIO);
    }
    if (can_do_start(options.interface) != 0) {
      std::snprintf(what, sizeof what, "can_do_start(%s)", options.interface);
      return error_.set_errno(what, errno != 0 ? errno : EIO);
    }
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return error_.set_errno("socket(AF_CAN, SOCK_RAW, CAN_RAW)", errno);
  const unsigned index = if_nametoindex(options.interface);
  if (index == 0) {
    const int err = errno;
    ::close(fd);
    char what[64];
    std::snprintf(what, sizeof what, "if_nametoindex(%s)", options.interface);
    return error_.set_errno(what, err);
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    return error_.set_errno("bind(AF_CAN)", err);
  }
  const int own = options.receive_own_messages ? 1 : 0;
  setsockopt(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, &own, sizeof own);
  const int on = 1;
  timestamps_ = setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) == 0 ||
                setsockopt(fd, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) == 0;
  const can_err_mask_t no_errors = 0;
  setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &no_errors, sizeof no_errors);
  fd_ = fd;
  counters_ = CanCounters{};
  return Status::kOk;
}

Status SocketCanBus::send(const CanFrame& frame) {
  if (fd_ < 0) return Status::kNotOpen;
  std::uint8_t bytes[kSocketCanFrameBytes];
  const Status encoded = encode_socketcan_frame(frame, bytes);
  if (encoded != Status::kOk) return encoded;
  const ssize_t n = ::write(fd_, bytes, sizeof bytes);
  if (n == static_cast<ssize_t>(sizeof bytes)) {
    ++counters_.tx_frames;
    return Status::kOk;
  }
  if (n < 0 && (errno == EAGAIN || errno == ENOBUFS)) {  // TX queue full: caller retries later
    ++counters_.tx_would_block;
    return Status::kWouldBlock;
  }
  return error_.set_errno("write(can)", n < 0 ? errno : EIO);
}

Status SocketCanBus::receive(CanRxFrame& out) {
  if (fd_ < 0) return Status::kNotOpen;
  alignas(8) std::uint8_t bytes[kSocketCanFrameBytes];
  alignas(cmsghdr) std::uint8_t control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(timeval))];
  iovec iov{bytes, sizeof bytes};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) return Status::kWouldBlock;
    return error_.set_errno("recvmsg(can)", errno);
  }
  if ((msg.msg_flags & MSG_TRUNC) != 0 ||
      decode_socketcan_frame(std::span<const std::uint8_t>(bytes, static_cast<std::size_t>(n)), out) != Status::kOk) {
    ++counters_.rx_malformed;
    return Status::kMalformed;
  }
  out.timestamp_ns = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      out.timestamp_ns = realtime_stamp_to_monotonic_ns(ts);
    } else if (c->cmsg_type == SCM_TIMESTAMP) {
      timeval tv{};
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      out.timestamp_ns = realtime_stamp_to_monotonic_ns(timespec{tv.tv_sec, tv.tv_usec * 1000});
    }
  }
  if (out.timestamp_ns == 0) {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    out.timestamp_ns = to_ns(now);
  }
  if (out.error) {
    ++counters_.rx_errors;
  } else {
    ++counters_.rx_frames;
  }
  return Status::kOk;
}

Status SocketCanBus::set_filters(std::span<const CanFilter> filters) {
  if (fd_ < 0) return Status::kNotOpen;
  if (filters.size() > kMaxCanFilters) return Status::kInvalidArgument;
  can_filter kernel[kMaxCanFilters];
  for (std::size_t i = 0; i < filters.size(); ++i) {
    // CanFrame's id encoding is SocketCAN's (bit 31 = CAN_EFF_FLAG), so the values map 1:1.
    kernel[i].can_id = filters[i].id;
    kernel[i].can_mask = filters[i].mask;
  }
  const socklen_t bytes = static_cast<socklen_t>(filters.size() * sizeof(can_filter));
  if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.empty() ? nullptr : kernel, bytes) != 0) {
    return error_.set_errno("setsockopt(CAN_RAW_FILTER)", errno);
  }
  return Status::kOk;
}

Status SocketCanBus::accept_all() {
  const CanFilter all{0, 0};
  return set_filters(std::span<const CanFilter>(&all, 1));
}

Status SocketCanBus::set_error_mask(std::uint32_t error_classes) {
  if (fd_ < 0) return Status::kNotOpen;
  const can_err_mask_t mask = error_classes & CAN_ERR_MASK;
  if (setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) != 0) {
    return error_.set_errno("setsockopt(CAN_RAW_ERR_FILTER)", errno);
  }
  return Status::kOk;
}

}  // namespace v2xloc::hal
