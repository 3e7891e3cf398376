// USB HID device: whole reports in and out of caller buffers. Numbered reports carry their report
// id in byte 0 (hidapi convention). Report format of the IMU: hal/HID_IMU_REPORT.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "hal/status.hpp"

namespace v2xloc::hal {

struct HidReportInfo {
  std::size_t size = 0;
  std::int64_t timestamp_ns = 0;  // time the report was read (Clock::monotonic_ns base)
};

class HidDevice {
 public:
  virtual ~HidDevice() = default;
  // Non-blocking: kWouldBlock when no input report is queued.
  virtual Status read_report(std::span<std::uint8_t> buffer, HidReportInfo& info) = 0;
  virtual Status write_report(std::span<const std::uint8_t> report) = 0;
};

}  // namespace v2xloc::hal
