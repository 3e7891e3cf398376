// HID device driven by a script of timestamped input reports (e.g. the IMU reports of a
// recording): a report becomes readable once the clock reaches its time stamp, and is read with
// that stamp (its arrival, as a driver stamping in the interrupt would give), so a replay does not
// depend on when the reader polls. Output reports written by the firmware are recorded.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "hal/clock.hpp"
#include "hal/emulated/hid_script.hpp"
#include "hal/hid_device.hpp"

namespace v2xloc::hal {

class ScriptedHidDevice final : public HidDevice {
 public:
  static constexpr std::size_t kMaxReportBytes = kMaxHidScriptReportBytes;
  struct Report {
    std::int64_t timestamp_ns = 0;
    std::uint8_t size = 0;
    std::array<std::uint8_t, kMaxReportBytes> bytes{};
  };

  explicit ScriptedHidDevice(const Clock& clock) : clock_(clock) {}

  // Reports must be queued in non-decreasing time order; at most 64 bytes.
  Status push_report(std::int64_t timestamp_ns, std::span<const std::uint8_t> report);
  // Text script (hal/emulated/hid_script.hpp), one report per line: "<monotonic_ns> <hex bytes>".
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
