#include "hal/emulated/scripted_hid_device.hpp"

#include <cstdio>
#include <cstring>

#include "hal/emulated/hid_script.hpp"

namespace v2xloc::hal {

Status ScriptedHidDevice::push_report(std::int64_t timestamp_ns, std::span<const std::uint8_t> report) {
  if (report.empty() || report.size() > kMaxReportBytes) return Status::kInvalidArgument;
  if (!reports_.empty() && timestamp_ns < reports_.back().timestamp_ns) return Status::kInvalidArgument;
  Report r;
  r.timestamp_ns = timestamp_ns;
  r.size = static_cast<std::uint8_t>(report.size());
  std::memcpy(r.bytes.data(), report.data(), report.size());
  reports_.push_back(r);
  return Status::kOk;
}

Status ScriptedHidDevice::load_script(const char* path) {
  std::FILE* f = std::fopen(path, "r");
  if (f == nullptr) return Status::kIoError;
  char line[512];
  Status result = Status::kOk;
  HidScriptLine report;
  while (result == Status::kOk && std::fgets(line, sizeof line, f) != nullptr) {
    const HidScriptParse parsed = parse_hid_script_line(line, report);
    if (parsed == HidScriptParse::kMalformed) result = Status::kMalformed;
    if (parsed == HidScriptParse::kReport)
      result = push_report(report.timestamp_ns, std::span<const std::uint8_t>(report.bytes.data(), report.size));
  }
  std::fclose(f);
  return result;
}

Status ScriptedHidDevice::read_report(std::span<std::uint8_t> buffer, HidReportInfo& info) {
  if (reports_.empty() || reports_.front().timestamp_ns > clock_.monotonic_ns()) return Status::kWouldBlock;
  const Report r = reports_.front();
  reports_.pop_front();
  if (buffer.size() < r.size) {  // consumed and discarded, like a truncated datagram
    info.size = 0;
    return Status::kBufferTooSmall;
  }
  std::memcpy(buffer.data(), r.bytes.data(), r.size);
  info.size = r.size;
  info.timestamp_ns = r.timestamp_ns;  // its arrival, however late it is read
  return Status::kOk;
}

Status ScriptedHidDevice::write_report(std::span<const std::uint8_t> report) {
  if (report.empty() || report.size() > kMaxReportBytes) return Status::kInvalidArgument;
  Report r;
  r.timestamp_ns = clock_.monotonic_ns();
  r.size = static_cast<std::uint8_t>(report.size());
  std::memcpy(r.bytes.data(), report.data(), report.size());
  written_.push_back(r);
  return Status::kOk;
}

}  // namespace v2xloc::hal
