#include "hal/linux/hidapi_device.hpp"

#include <hidapi/hidapi.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>

#include "hal/linux/linux_clock.hpp"

namespace v2xloc::hal {

HidapiDevice::~HidapiDevice() { close(); }

void HidapiDevice::close() {
  if (device_ != nullptr) hid_close(device_);
  device_ = nullptr;
  // hid_exit() is not called: other devices of the process may still use the library.
}

void HidapiDevice::record_hid_error(const char* what) {
  char text[160] = "unknown hidapi error";
  const wchar_t* wide = hid_error(device_);
  if (wide != nullptr) {
    const std::size_t n = std::wcstombs(text, wide, sizeof text - 1);
    if (n != static_cast<std::size_t>(-1)) text[n] = '\0';
  }
  char full[192];
  std::snprintf(full, sizeof full, "%s failed: %s", what, text);
  error_.set(full);
}

Status HidapiDevice::open(const HidapiOptions& o) {
  close();
  error_.clear();
  if (!library_initialised_) {
    if (hid_init() != 0) {
      record_hid_error("hid_init");
      return Status::kIoError;
    }
    library_initialised_ = true;
  }
  device_ = o.path != nullptr ? hid_open_path(o.path) : hid_open(o.vendor_id, o.product_id, nullptr);
  if (device_ == nullptr) {
    char what[96];
    if (o.path != nullptr) {
      std::snprintf(what, sizeof what, "hid_open_path(%s)", o.path);
    } else {
      std::snprintf(what, sizeof what, "hid_open(%04x:%04x)", o.vendor_id, o.product_id);
    }
    record_hid_error(what);
    return Status::kUnsupported;
  }
  return Status::kOk;
}

Status HidapiDevice::read_report_timeout(std::span<std::uint8_t> buffer, HidReportInfo& info, int timeout_ms) {
  if (device_ == nullptr) return Status::kNotOpen;
  const int n = hid_read_timeout(device_, buffer.data(), buffer.size(), timeout_ms);
  if (n < 0) {
    record_hid_error("hid_read_timeout");
    return Status::kIoError;
  }
  if (n == 0) return timeout_ms == 0 ? Status::kWouldBlock : Status::kTimeout;
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  info.size = static_cast<std::size_t>(n);
  info.timestamp_ns = to_ns(now);
  return Status::kOk;
}

Status HidapiDevice::read_report(std::span<std::uint8_t> buffer, HidReportInfo& info) {
  return read_report_timeout(buffer, info, 0);
}

Status HidapiDevice::write_report(std::span<const std::uint8_t> report) {
  if (device_ == nullptr) return Status::kNotOpen;
  if (report.empty()) return Status::kInvalidArgument;
  const int n = hid_write(device_, report.data(), report.size());
  if (n < 0) {
    record_hid_error("hid_write");
    return Status::kIoError;
  }
  return Status::kOk;
}

}  // namespace v2xloc::hal
