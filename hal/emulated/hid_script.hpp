// The text form of timestamped HID reports, one per line: "<time_ns> <hex bytes>", e.g.
// "1000 01 2a 00 ...", '#' starts a comment. ScriptedHidDevice reads it; a recording's IMU stream
// (host_sim/RECORDING_FORMAT.md) is written in it.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace v2xloc::hal {

inline constexpr std::size_t kMaxHidScriptReportBytes = 64;  // full-speed USB interrupt packet

struct HidScriptLine {
  std::int64_t timestamp_ns = 0;
  std::uint8_t size = 0;
  std::array<std::uint8_t, kMaxHidScriptReportBytes> bytes{};
};

enum class HidScriptParse : std::uint8_t { kReport, kBlank, kMalformed };

// kMalformed: a byte above 0xff, more than 64 bytes, or a time without bytes.
HidScriptParse parse_hid_script_line(const char* line, HidScriptLine& out);
// Writes one line (with '\n') into `out`; returns its length, 0 when it does not fit.
std::size_t format_hid_script_line(std::int64_t timestamp_ns, std::span<const std::uint8_t> report,
                                   std::span<char> out);

}  // namespace v2xloc::hal
