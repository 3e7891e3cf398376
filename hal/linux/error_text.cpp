#include "hal/linux/error_text.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace v2xloc::hal::linux_backend {

Status status_from_errno(int err) {
  switch (err) {
    case EAGAIN: return Status::kWouldBlock;
    case EPERM:
    case EACCES: return Status::kPermissionDenied;
    case EINVAL: return Status::kInvalidArgument;
    case EAFNOSUPPORT:
    case EPROTONOSUPPORT:
    case ENODEV:
    case ENOENT:
    case ENOSYS: return Status::kUnsupported;
    default: return Status::kIoError;
  }
}

Status ErrorText::set_errno(const char* what, int err) {
  char reason[96];
  // GNU strerror_r may return a static string instead of filling the buffer.
  const char* text = strerror_r(err, reason, sizeof reason);
  std::snprintf(text_, sizeof text_, "%s failed: %s", what, text);
  return status_from_errno(err);
}

void ErrorText::set(const char* what) { std::snprintf(text_, sizeof text_, "%s", what); }

}  // namespace v2xloc::hal::linux_backend
