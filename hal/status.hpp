// Result of every HAL call. Calls never throw; kWouldBlock is the normal "nothing yet" answer of
// a non-blocking poll, not an error.
#pragma once

#include <cstdint>

namespace v2xloc::hal {

enum class Status : std::uint8_t {
  kOk,
  kWouldBlock,       // non-blocking call: nothing to read / cannot write right now
  kTimeout,          // a bounded wait expired
  kNotOpen,          // the backend was never opened or was closed
  kInvalidArgument,
  kBufferTooSmall,   // caller buffer too small; the datagram/report was truncated and discarded
  kMalformed,        // received data of the wrong size/shape; dropped and counted
  kUnsupported,      // the backend cannot do this (e.g. output on an input line)
  kPermissionDenied,
  kIoError,
};

const char* to_string(Status status);

}  // namespace v2xloc::hal
