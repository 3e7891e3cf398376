#include "hal/emulated/hid_script.hpp"

#include <cstdio>
#include <cstdlib>

namespace v2xloc::hal {

HidScriptParse parse_hid_script_line(const char* line, HidScriptLine& out) {
  const char* cursor = line;
  char* end = nullptr;
  const long long t = std::strtoll(cursor, &end, 10);
  if (end == cursor) {
    while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r' || *cursor == '\n') ++cursor;
    return *cursor == '\0' || *cursor == '#' ? HidScriptParse::kBlank : HidScriptParse::kMalformed;
  }
  out = HidScriptLine{};
  out.timestamp_ns = t;
  cursor = end;
  std::size_t n = 0;
  for (;;) {
    while (*cursor == ' ' || *cursor == '\t') ++cursor;
    if (*cursor == '#') break;
    const unsigned long v = std::strtoul(cursor, &end, 16);
    if (end == cursor) break;
    if (v > 0xFF || n == out.bytes.size()) return HidScriptParse::kMalformed;
    out.bytes[n++] = static_cast<std::uint8_t>(v);
    cursor = end;
  }
  while (*cursor == ' ' || *cursor == '\t' || *cursor == '\r' || *cursor == '\n') ++cursor;
  if (n == 0 || (*cursor != '\0' && *cursor != '#')) return HidScriptParse::kMalformed;
  out.size = static_cast<std::uint8_t>(n);
  return HidScriptParse::kReport;
}

std::size_t format_hid_script_line(std::int64_t timestamp_ns, std::span<const std::uint8_t> report,
                                   std::span<char> out) {
  int used = std::snprintf(out.data(), out.size(), "%lld", static_cast<long long>(timestamp_ns));
  for (const std::uint8_t b : report) {
    if (used < 0 || static_cast<std::size_t>(used) >= out.size()) return 0;
    used += std::snprintf(out.data() + used, out.size() - static_cast<std::size_t>(used), " %02x", b);
  }
  if (used < 0 || static_cast<std::size_t>(used) + 1 >= out.size()) return 0;
  out[static_cast<std::size_t>(used)] = '\n';
  out[static_cast<std::size_t>(used) + 1] = '\0';
  return static_cast<std::size_t>(used) + 1;
}

}  // namespace v2xloc::hal
