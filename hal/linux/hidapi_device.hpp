// hidapi backend (hidraw flavour) for the USB HID IMU / yaw-rate sensor. Report format:
// hal/HID_IMU_REPORT.md. Reads are non-blocking (hid_read_timeout with 0 ms).
#pragma once

#include <cstdint>

#include "hal/hid_device.hpp"
#include "hal/hid_imu_report.hpp"
#include "hal/linux/error_text.hpp"

struct hid_device_;

namespace v2xloc::hal {

struct HidapiOptions {
  std::uint16_t vendor_id = hid_imu::kVendorId;
  std::uint16_t product_id = hid_imu::kProductId;
  const char* path = nullptr;  // hidraw path from hid_enumerate; overrides VID/PID when set
};

class HidapiDevice final : public HidDevice {
 public:
  HidapiDevice() = default;
  ~HidapiDevice() override;
  HidapiDevice(const HidapiDevice&) = delete;
  HidapiDevice& operator=(const HidapiDevice&) = delete;

  Status open(const HidapiOptions& options);
  void close();
  const char* last_error() const { return error_.c_str(); }
  // Blocking variant for a dedicated reader: waits up to timeout_ms (-1 = forever).
  Status read_report_timeout(std::span<std::uint8_t> buffer, HidReportInfo& info, int timeout_ms);

  // Give a buffer at least as large as the largest input report: hidraw truncates silently.
  Status read_report(std::span<std::uint8_t> buffer, HidReportInfo& info) override;
  Status write_report(std::span<const std::uint8_t> report) override;

 private:
  void record_hid_error(const char* what);

  hid_device_* device_ = nullptr;
  bool library_initialised_ = false;
  linux_backend::ErrorText error_;
};

}  // namespace v2xloc::hal
