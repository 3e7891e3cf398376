// candump log files as can-utils writes them (`candump -L`, read by canplayer, log2asc and
// python-can's CanutilsLogReader): one frame per line, `(1700000000.123456) can0 123#DEADBEEF`.
// Classic CAN only: 3-hex-digit standard ids, 8-hex-digit extended ids, 0-8 data bytes.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

#include "hal/can_frame.hpp"

namespace v2xloc::sim {

struct CandumpRecord {
  std::int64_t timestamp_us = 0;  // microseconds since the epoch (exact: no float round trip)
  std::string interface = "can0";
  hal::CanFrame frame;
};

// Seconds -> microseconds, rounded to nearest (for simulated time stamps).
std::int64_t candump_timestamp_us(double seconds);

// One line without the newline. Standard ids as 3 hex digits, extended as 8 (upper case).
std::string format_candump_line(const CandumpRecord& record);

// Parses one line (trailing CR/whitespace tolerated). False + a reason for anything malformed:
// missing or bad time stamp, bad interface, bad id, odd hex digits, > 8 bytes, CAN FD / remote
// frames (not supported by CanFrame), trailing garbage.
bool parse_candump_line(std::string_view line, CandumpRecord& out, std::string& error);

struct CandumpParseError {
  std::size_t line_number = 0;  // 1-based
  std::string message;
  std::string text;
};

struct CandumpLog {
  std::vector<CandumpRecord> records;
  std::vector<CandumpParseError> errors;  // garbage lines are reported and skipped
};

// Reads every line; blank lines are skipped silently, malformed lines go to errors.
CandumpLog read_candump(std::istream& in);
CandumpLog read_candump_file(const std::string& path);  // errors[0] explains a missing file

class CandumpWriter {
 public:
  explicit CandumpWriter(std::ostream& out, std::string interface = "can0");
  void write(std::int64_t timestamp_us, const hal::CanFrame& frame);
  void write(double t_seconds, const hal::CanFrame& frame) { write(candump_timestamp_us(t_seconds), frame); }
  std::size_t frames_written() const { return frames_; }

 private:
  std::ostream& out_;
  std::string interface_;
  std::size_t frames_ = 0;
};

}  // namespace v2xloc::sim
