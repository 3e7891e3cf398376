// POSIX UDP backend: non-blocking IPv4 socket, bind, optional connect to a default peer,
// optional multicast group membership, kernel receive time stamps (SO_TIMESTAMPNS).
#pragma once

#include <cstdint>

#include "hal/datagram_link.hpp"
#include "hal/linux/error_text.hpp"

namespace v2xloc::hal {

struct UdpOptions {
  Ipv4Endpoint bind{0x7F000001u, 0};  // port 0 = ephemeral (see local_endpoint())
  bool has_peer = false;               // default destination for send()
  Ipv4Endpoint peer;
  bool connect_peer = false;           // also filter received datagrams to the peer
  std::uint32_t multicast_group = 0;   // 0 = none; else joined on multicast_interface
  std::uint32_t multicast_interface = 0;  // host order; join + send interface, 0 = kernel picks
  bool multicast_loop = true;
  bool reuse_address = false;          // SO_REUSEADDR (several receivers of one group/port)
  int receive_buffer_bytes = 0;        // SO_RCVBUF, 0 = kernel default
};

class UdpLink final : public DatagramLink {
 public:
  UdpLink() = default;
  ~UdpLink() override;
  UdpLink(const UdpLink&) = delete;
  UdpLink& operator=(const UdpLink&) = delete;

  Status open(const UdpOptions& options);
  void close();
  int fd() const { return fd_; }
  Ipv4Endpoint local_endpoint() const { return local_; }
  const char* last_error() const { return error_.c_str(); }
  Status set_peer(const Ipv4Endpoint& peer);

  Status send(std::span<const std::uint8_t> datagram) override;
  Status send_to(const Ipv4Endpoint& to, std::span<const std::uint8_t> datagram) override;
  Status receive(std::span<std::uint8_t> buffer, DatagramInfo& info) override;

 private:
  Status fail(const char* what);

  int fd_ = -1;
  bool has_peer_ = false;
  bool connected_ = false;
  Ipv4Endpoint peer_{};
  Ipv4Endpoint local_{};
  linux_backend::ErrorText error_;
};

}  // namespace v2xloc::hal
