// Fixed-size "what failed and why" text for backends (e.g. "socket(AF_CAN) failed: Address
// family not supported by protocol"), so tests and main can print precise reasons.
#pragma once

#include <cstddef>

#include "hal/status.hpp"

namespace v2xloc::hal::linux_backend {

class ErrorText {
 public:
  // Records "<what> failed: strerror(err)" and returns the Status matching errno `err`.
  Status set_errno(const char* what, int err);
  void set(const char* what);
  void clear() { text_[0] = '\0'; }
  const char* c_str() const { return text_; }

 private:
  char text_[192] = {};
};

Status status_from_errno(int err);

}  // namespace v2xloc::hal::linux_backend
