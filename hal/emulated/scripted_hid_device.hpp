// HID device driven by a script of timestamped input reports (e.g. the IMU reports of a
// recording): a report becomes readable once the clock reaches its time stamp. Output reports
// written by the firmware are recorded.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "hal/clock.hpp"
#include "hal/hid_device.hpp"

namespace v2xloc::hal {

class ScriptedHidDevice final : public HidDevice {
 public:
  static constexpr std::size_t kMaxReportBytes = 64;  // full-speed USB interrupt packet
  struct Report {
    std::int64_t timestamp_ns = 0;
    std::uint8_t size = 0;
    std::array<std::uint8_t, kMaxReportBytes> bytes{};
  };

  explicit ScriptedHidDevice(const Clock& clock) : clock_(clock) {}

  // Reports must be queued in non-decreasing time order; at most 64 bytes.
  Status push_report(std::int64_t timestamp_ns, std::span<const std::uint8_t> report);
  // Text script, one report per line: "<monotonic_ns> <hex bytes>", e.g. "1000 01 2a 00 ...".
  Status load_script(const char* path);
  std::size_t pending_reports() const { return reports_.size(); }
  const std::vector<Report>& written_reports() const { return written_; }

  Status read_report(std::span<std::uint8_t> buffer, HidReportInfo& info) override;
  Status write_report(std::span<const std::uint8_t> report) override;

 private:
  const Clock& clock_;
  std::deque<Report> reports_;
  std::vector<Report> written_;
};

}  // namespace v2xloc::hal
