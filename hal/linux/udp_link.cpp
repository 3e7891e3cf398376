#include "hal/linux/udp_link.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "hal/linux/linux_clock.hpp"

namespace v2xloc::hal {
namespace {

sockaddr_in to_sockaddr(const Ipv4Endpoint& e) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(e.address);
  a.sin_port = htons(e.port);
  return a;
}

}  // namespace

UdpLink::~UdpLink() { close(); }

void UdpLink::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  has_peer_ = connected_ = false;
}

Status UdpLink::fail(const char* what) {
  const int err = errno;
  const Status s = error_.set_errno(what, err);
  close();
  return s;
}

Status UdpLink::open(const UdpOptions& o) {
  close();
  error_.clear();
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return fail("socket(AF_INET, SOCK_DGRAM)");
  const int on = 1;
  if (o.reuse_address && setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on) != 0) {
    return fail("setsockopt(SO_REUSEADDR)");
  }
  if (o.receive_buffer_bytes > 0 &&
      setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &o.receive_buffer_bytes, sizeof o.receive_buffer_bytes) != 0) {
    return fail("setsockopt(SO_RCVBUF)");
  }
  setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);  // best effort; else read time
  const sockaddr_in local = to_sockaddr(o.bind);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0) return fail("bind(udp)");
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  if (getsockname(fd_, reinterpret_cast<sockaddr*>(&bound), &len) != 0) return fail("getsockname(udp)");
  local_ = Ipv4Endpoint{ntohl(bound.sin_addr.s_addr), ntohs(bound.sin_port)};

  if (o.multicast_group != 0) {
    ip_mreq mreq{};
    mreq.imr_multiaddr.s_addr = htonl(o.multicast_group);
    mreq.imr_interface.s_addr = htonl(o.multicast_interface);
    if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0) return fail("IP_ADD_MEMBERSHIP");
  }
  if (o.multicast_interface != 0) {  // outgoing multicast leaves through this interface
    in_addr iface{};
    iface.s_addr = htonl(o.multicast_interface);
    if (setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_IF, &iface, sizeof iface) != 0) return fail("IP_MULTICAST_IF");
  }
  const unsigned char loop = o.multicast_loop ? 1 : 0;
  if (setsockopt(fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof loop) != 0) return fail("IP_MULTICAST_LOOP");
  if (o.has_peer) {
    peer_ = o.peer;
    has_peer_ = true;
    if (o.connect_peer) {
      const sockaddr_in peer = to_sockaddr(o.peer);
      if (::connect(fd_, reinterpret_cast<const sockaddr*>(&peer), sizeof peer) != 0) return fail("connect(udp)");
      connected_ = true;
    }
  }
  return Status::kOk;
}

Status UdpLink::set_peer(const Ipv4Endpoint& peer) {
  if (fd_ < 0) return Status::kNotOpen;
  if (connected_) return Status::kUnsupported;
  peer_ = peer;
  has_peer_ = true;
  return Status::kOk;
}

Status UdpLink::send(std::span<const std::uint8_t> datagram) {
  if (fd_ < 0) return Status::kNotOpen;
  if (!has_peer_) return Status::kInvalidArgument;
  if (!connected_) return send_to(peer_, datagram);
  const ssize_t n = ::send(fd_, datagram.data(), datagram.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  if (n == static_cast<ssize_t>(datagram.size())) return Status::kOk;
  return error_.set_errno("send(udp)", n < 0 ? errno : EMSGSIZE);
}

Status UdpLink::send_to(const Ipv4Endpoint& to, std::span<const std::uint8_t> datagram) {
  if (fd_ < 0) return Status::kNotOpen;
  const sockaddr_in addr = to_sockaddr(to);
  const ssize_t n = ::sendto(fd_, datagram.data(), datagram.size(), MSG_DONTWAIT | MSG_NOSIGNAL,
                             connected_ ? nullptr : reinterpret_cast<const sockaddr*>(&addr),
                             connected_ ? 0 : sizeof addr);
  if (n == static_cast<ssize_t>(datagram.size())) return Status::kOk;
  return error_.set_errno("sendto(udp)", n < 0 ? errno : EMSGSIZE);
}

Status UdpLink::receive(std::span<std::uint8_t> buffer, DatagramInfo& info) {
  if (fd_ < 0) return Status::kNotOpen;
  alignas(cmsghdr) std::uint8_t control[CMSG_SPACE(sizeof(timespec))];
  sockaddr_in from{};
  iovec iov{buffer.data(), buffer.size()};
  msghdr msg{};
  msg.msg_name = &from;
  msg.msg_namelen = sizeof from;
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) return Status::kWouldBlock;
    return error_.set_errno("recvmsg(udp)", errno);
  }
  info.size = static_cast<std::size_t>(n);
  info.from = Ipv4Endpoint{ntohl(from.sin_addr.s_addr), ntohs(from.sin_port)};
  info.timestamp_ns = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      info.timestamp_ns = realtime_stamp_to_monotonic_ns(ts);
    }
  }
  if (info.timestamp_ns == 0) {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    info.timestamp_ns = to_ns(now);
  }
  if ((msg.msg_flags & MSG_TRUNC) != 0) {  // the rest of the datagram is gone: never pass it on
    info.size = 0;
    return Status::kBufferTooSmall;
  }
  return Status::kOk;
}

}  // namespace v2xloc::hal
