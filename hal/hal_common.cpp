// Small helpers behind the interface headers (status names, filter matching, address parsing).
#include <cstdio>

#include "hal/can_bus.hpp"
#include "hal/datagram_link.hpp"
#include "hal/status.hpp"

namespace v2xloc::hal {

const char* to_string(Status status) {
  switch (status) {
    case Status::kOk: return "ok";
    case Status::kWouldBlock: return "would block";
    case Status::kTimeout: return "timeout";
    case Status::kNotOpen: return "not open";
    case Status::kInvalidArgument: return "invalid argument";
    case Status::kBufferTooSmall: return "buffer too small";
    case Status::kMalformed: return "malformed";
    case Status::kUnsupported: return "unsupported";
    case Status::kPermissionDenied: return "permission denied";
    case Status::kIoError: return "I/O error";
  }
  return "unknown";
}

bool can_filter_matches(const CanFilter& filter, std::uint32_t frame_id) {
  return (frame_id & filter.mask) == (filter.id & filter.mask);
}

bool parse_ipv4(const char* text, std::uint32_t& address) {
  unsigned a = 0, b = 0, c = 0, d = 0;
  char tail = 0;
  if (text == nullptr || std::sscanf(text, "%u.%u.%u.%u%c", &a, &b, &c, &d, &tail) != 4) return false;
  if (a > 255 || b > 255 || c > 255 || d > 255) return false;
  address = (a << 24) | (b << 16) | (c << 8) | d;
  return true;
}

}  // namespace v2xloc::hal
