// UDP-like datagram link: whole datagrams in and out of caller buffers, non-blocking.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/status.hpp"

namespace v2xloc::hal {

struct Ipv4Endpoint {
  std::uint32_t address = 0;  // host byte order, e.g. 0x7F000001 for 127.0.0.1
  std::uint16_t port = 0;
  bool operator==(const Ipv4Endpoint&) const = default;
};

struct DatagramInfo {
  std::size_t size = 0;            // bytes written into the caller buffer
  Ipv4Endpoint from;
  std::int64_t timestamp_ns = 0;   // receive time, CLOCK_MONOTONIC / Clock::monotonic_ns base
};

class DatagramLink {
 public:
  virtual ~DatagramLink() = default;
  // Sends to the connected / default peer.
  virtual Status send(std::span<const std::uint8_t> datagram) = 0;
  virtual Status send_to(const Ipv4Endpoint& to, std::span<const std::uint8_t> datagram) = 0;
  // kWouldBlock when nothing is queued; kBufferTooSmall when the datagram did not fit (it is
  // consumed and discarded, never returned partially as if complete).
  virtual Status receive(std::span<std::uint8_t> buffer, DatagramInfo& info) = 0;
};

// "a.b.c.d" -> host-order address; false on anything else.
bool parse_ipv4(const char* text, std::uint32_t& address);

}  // namespace v2xloc::hal
