// A small DBC reader for the tests (BO_ / SG_ lines only, simple multiplexing: one `M` signal and
// `m<k>` signals): an independent reading of the wire format, so the codec is checked against the
// file and not against itself.
#pragma once

#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace v2xloc::test {

struct DbcSignal {
  std::string name;
  unsigned start = 0, length = 0;
  bool little_endian = true, is_signed = false;
  double factor = 1.0, offset = 0.0, min = 0.0, max = 0.0;
  std::string unit;
  bool multiplexer = false;  // `M`: its value says which m<k> signals the frame holds
  int mux_value = -1;        // `m<k>`: present only when the multiplexer reads k; -1: always present

  // Independent bit extraction (Intel: start bit is the LSB, bits run upwards through the bytes).
  double decode(const std::uint8_t* data) const {
    std::uint64_t raw = 0;
    for (unsigned i = 0; i < length; ++i) {
      const unsigned bit = start + i;
      raw |= static_cast<std::uint64_t>((data[bit >> 3] >> (bit & 7)) & 1) << i;
    }
    double value = static_cast<double>(raw);
    if (is_signed && (raw >> (length - 1)) & 1) value -= std::ldexp(1.0, static_cast<int>(length));
    return value * factor + offset;
  }
};

struct DbcMessage {
  std::uint32_t id = 0;
  std::string name;
  unsigned dlc = 0;
  std::map<std::string, DbcSignal> signals;

  const DbcSignal* multiplexer() const {
    for (const auto& [n, s] : signals)
      if (s.multiplexer) return &s;
    return nullptr;
  }
  // The multiplexer values the m<k> signals use; {-1} for a message without multiplexing.
  std::vector<int> mux_values() const {
    std::set<int> v;
    for (const auto& [n, s] : signals)
      if (s.mux_value >= 0) v.insert(s.mux_value);
    return v.empty() ? std::vector<int>{-1} : std::vector<int>(v.begin(), v.end());
  }
  // The signals a frame holds when its multiplexer reads `mux` (-1: a plain message, all of them).
  std::map<std::string, DbcSignal> active(int mux) const {
    std::map<std::string, DbcSignal> out;
    for (const auto& [n, s] : signals)
      if (s.mux_value < 0 || s.mux_value == mux) out[n] = s;
    return out;
  }
};

struct Dbc {
  std::map<std::uint32_t, DbcMessage> messages;
  int baudrate = 0;
};

inline Dbc read_dbc(const std::string& path) {
  Dbc dbc;
  std::ifstream in(path);
  const std::regex bo(R"(^BO_ (\d+) (\w+): (\d+) (\w+)\s*$)");
  const std::regex sg(
      R"re(^ SG_ (\w+) (?:(M|m\d+) )?: (\d+)\|(\d+)@([01])([+-]) \(([^,]+),([^)]+)\) \[([^|]+)\|([^\]]+)\] "([^"]*)" (\w+(,\w+)*)\s*$)re");
  const std::regex bs(R"(^BS_: (\d+))");
  std::string line;
  DbcMessage* current = nullptr;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, bo)) {
      DbcMessage msg;
      msg.id = static_cast<std::uint32_t>(std::stoul(m[1]));
      msg.name = m[2];
      msg.dlc = static_cast<unsigned>(std::stoul(m[3]));
      current = &(dbc.messages[msg.id] = msg);
    } else if (current != nullptr && std::regex_match(line, m, sg)) {
      DbcSignal s;
      s.name = m[1];
      const std::string mux = m[2];
      s.multiplexer = mux == "M";
      if (!mux.empty() && mux[0] == 'm') s.mux_value = std::stoi(mux.substr(1));
      s.start = static_cast<unsigned>(std::stoul(m[3]));
      s.length = static_cast<unsigned>(std::stoul(m[4]));
      s.little_endian = m[5] == "1";
      s.is_signed = m[6] == "-";
      s.factor = std::stod(m[7]);
      s.offset = std::stod(m[8]);
      s.min = std::stod(m[9]);
      s.max = std::stod(m[10]);
      s.unit = m[11];
      current->signals[s.name] = s;
    } else if (std::regex_search(line, m, bs)) {
      dbc.baudrate = std::stoi(m[1]);
    } else if (line.rfind("BO_", 0) == 0 || line.rfind(" SG_", 0) == 0) {
      ADD_FAILURE() << "unparsed DBC line: " << line;
    }
  }
  return dbc;
}

}  // namespace v2xloc::test
