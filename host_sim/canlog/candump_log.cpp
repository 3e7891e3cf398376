#include "host_sim/canlog/candump_log.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <istream>
#include <ostream>

namespace v2xloc::sim {
namespace {

constexpr std::int64_t kMaxSeconds = 999'999'999'999;

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool parse_decimal(std::string_view s, std::int64_t& value) {
  if (s.empty() || s.size() > 18) return false;
  value = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    value = value * 10 + (c - '0');
  }
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == '\n' || s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  return s;
}

// "(seconds.microseconds)" and the space after it, consumed from the front of s.
bool parse_time_stamp(std::string_view& s, std::int64_t& timestamp_us, std::string& error) {
  if (s.empty() || s.front() != '(') {
    error = "expected '(' time stamp";
    return false;
  }
  const std::size_t close = s.find(')');
  if (close == std::string_view::npos) {
    error = "unterminated time stamp";
    return false;
  }
  const std::string_view ts = s.substr(1, close - 1);
  const std::size_t dot = ts.find('.');
  std::int64_t sec = 0, usec = 0;
  if (dot == std::string_view::npos || !parse_decimal(ts.substr(0, dot), sec) || ts.size() - dot - 1 != 6 ||
      !parse_decimal(ts.substr(dot + 1), usec)) {
    error = "bad time stamp (want seconds.microseconds)";
    return false;
  }
  // Microseconds must fit an int64: 12 digits of seconds (31,700 years) is the most that can.
  if (sec > kMaxSeconds) {
    error = "time stamp seconds above " + std::to_string(kMaxSeconds);
    return false;
  }
  s.remove_prefix(close + 1);
  if (s.empty() || s.front() != ' ') {
    error = "expected a space after the time stamp";
    return false;
  }
  timestamp_us = sec * 1000000 + usec;
  return true;
}

// The interface name (1-15 printable characters but '#', '(' and ')'), consumed with the blanks
// around it.
bool parse_interface(std::string_view& s, std::string_view& iface, std::string& error) {
  s = trim(s);
  const std::size_t space = s.find(' ');
  if (space == std::string_view::npos || space == 0 || space > 15) {
    error = "missing or bad interface name";
    return false;
  }
  iface = s.substr(0, space);
  for (char c : iface) {
    if (c <= ' ' || c == '#' || c == '(' || c == ')') {
      error = "bad interface name";
      return false;
    }
  }
  s = trim(s.substr(space + 1));
  return true;
}

// 3 hex digits (standard, <= 0x7FF) or 8 (extended, no error/flag bits; kExtendedFlag set).
bool parse_id(std::string_view id_text, std::uint32_t& id, std::string& error) {
  if (id_text.size() != 3 && id_text.size() != 8) {
    error = "id must have 3 (standard) or 8 (extended) hex digits";
    return false;
  }
  id = 0;
  for (char c : id_text) {
    const int v = hex_value(c);
    if (v < 0) {
      error = "id is not hexadecimal";
      return false;
    }
    id = (id << 4) | static_cast<std::uint32_t>(v);
  }
  if (id_text.size() == 3 && id > 0x7FFu) {
    error = "standard id above 0x7FF";
    return false;
  }
  if (id_text.size() == 8) {
    if (id > 0x1FFFFFFFu) {
      error = "error/flag bits in the id are not supported";
      return false;
    }
    id |= hal::CanFrame::kExtendedFlag;
  }
  return true;
}

// 0-8 data bytes as hex pairs; CAN FD ("##") and remote ("R") frames refused.
bool parse_data(std::string_view data_text, hal::CanFrame& frame, std::string& error) {
  if (!data_text.empty() && data_text.front() == '#') {
    error = "CAN FD frames are not supported";
    return false;
  }
  if (!data_text.empty() && (data_text.front() == 'R' || data_text.front() == 'r')) {
    error = "remote frames are not supported";
    return false;
  }
  if (data_text.size() % 2 != 0) {
    error = "odd number of data hex digits";
    return false;
  }
  if (data_text.size() > 16) {
    error = "more than 8 data bytes";
    return false;
  }
  frame.dlc = static_cast<std::uint8_t>(data_text.size() / 2);
  for (std::size_t i = 0; i < frame.dlc; ++i) {
    const int hi = hex_value(data_text[2 * i]), lo = hex_value(data_text[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      error = "data is not hexadecimal";
      return false;
    }
    frame.data[i] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  return true;
}

}  // namespace

std::int64_t candump_timestamp_us(double seconds) {
  return static_cast<std::int64_t>(std::floor(seconds * 1e6 + 0.5));
}

std::string format_candump_line(const CandumpRecord& r) {
  char buf[96];
  const bool extended = (r.frame.id & hal::CanFrame::kExtendedFlag) != 0u;
  const std::int64_t ts = r.timestamp_us < 0 ? 0 : r.timestamp_us;
  int n = std::snprintf(buf, sizeof buf, "(%lld.%06lld) %s ", static_cast<long long>(ts / 1000000),
                        static_cast<long long>(ts % 1000000), r.interface.c_str());
  std::string line(buf, static_cast<std::size_t>(n));
  n = extended ? std::snprintf(buf, sizeof buf, "%08X#", r.frame.id & 0x1FFFFFFFu)
               : std::snprintf(buf, sizeof buf, "%03X#", r.frame.id & 0x7FFu);
  line.append(buf, static_cast<std::size_t>(n));
  const std::uint8_t dlc = r.frame.dlc > 8 ? 8 : r.frame.dlc;
  for (std::uint8_t i = 0; i < dlc; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", r.frame.data[i]);
    line.append(buf, 2);
  }
  return line;
}

bool parse_candump_line(std::string_view line, CandumpRecord& out, std::string& error) {
  std::string_view s = trim(line);
  std::int64_t timestamp_us = 0;
  std::string_view iface;
  if (!parse_time_stamp(s, timestamp_us, error) || !parse_interface(s, iface, error)) return false;
  const std::size_t hash = s.find('#');
  if (hash == std::string_view::npos) {
    error = "missing '#' between id and data";
    return false;
  }
  hal::CanFrame frame;
  if (!parse_id(s.substr(0, hash), frame.id, error) || !parse_data(s.substr(hash + 1), frame, error)) return false;
  out.timestamp_us = timestamp_us;
  out.interface = std::string(iface);
  out.frame = frame;
  return true;
}

CandumpLog read_candump(std::istream& in) {
  CandumpLog log;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (trim(line).empty()) continue;
    CandumpRecord r;
    std::string error;
    if (parse_candump_line(line, r, error)) log.records.push_back(std::move(r));
    else log.errors.push_back({number, error, line});
  }
  return log;
}

CandumpLog read_candump_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    CandumpLog log;
    log.errors.push_back({0, "cannot open " + path, ""});
    return log;
  }
  return read_candump(in);
}

CandumpWriter::CandumpWriter(std::ostream& out, std::string interface)
    : out_(out), interface_(std::move(interface)) {}

void CandumpWriter::write(std::int64_t timestamp_us, const hal::CanFrame& frame) {
  CandumpRecord r;
  r.timestamp_us = timestamp_us;
  r.interface = interface_;
  r.frame = frame;
  out_ << format_candump_line(r) << '\n';
  ++frames_;
}

}  // namespace v2xloc::sim
