// Internal helpers shared by the readers and writers (not part of the public API).
#pragma once

#include "host_sim/cloud_io/point_cloud.hpp"

#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace v2xloc::cloud_io::detail {

static_assert(std::endian::native == std::endian::little,
              "cloud_io reads little-endian data with memcpy; add byte swapping for this target");

enum class Scalar : std::uint8_t { kI8, kU8, kI16, kU16, kI32, kU32, kI64, kU64, kF32, kF64 };

inline std::size_t scalar_size(Scalar s) {
  switch (s) {
    case Scalar::kI8: case Scalar::kU8: return 1;
    case Scalar::kI16: case Scalar::kU16: return 2;
    case Scalar::kI32: case Scalar::kU32: case Scalar::kF32: return 4;
    case Scalar::kI64: case Scalar::kU64: case Scalar::kF64: return 8;
  }
  return 0;
}

template <typename T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

template <typename T>
T load_swapped(const std::uint8_t* p) {
  std::uint8_t b[sizeof(T)];
  for (std::size_t i = 0; i < sizeof(T); ++i) b[i] = p[sizeof(T) - 1 - i];
  return load<T>(b);
}

// Reads one scalar of type s at p (size already bounds-checked by the caller) as double.
inline double load_scalar(Scalar s, const std::uint8_t* p, bool big_endian = false) {
  switch (s) {
    case Scalar::kI8: return static_cast<double>(static_cast<std::int8_t>(p[0]));
    case Scalar::kU8: return static_cast<double>(p[0]);
    case Scalar::kI16: return big_endian ? load_swapped<std::int16_t>(p) : load<std::int16_t>(p);
    case Scalar::kU16: return big_endian ? load_swapped<std::uint16_t>(p) : load<std::uint16_t>(p);
    case Scalar::kI32: return big_endian ? load_swapped<std::int32_t>(p) : load<std::int32_t>(p);
    case Scalar::kU32: return big_endian ? load_swapped<std::uint32_t>(p) : load<std::uint32_t>(p);
    case Scalar::kI64:
      return static_cast<double>(big_endian ? load_swapped<std::int64_t>(p) : load<std::int64_t>(p));
    case Scalar::kU64:
      return static_cast<double>(big_endian ? load_swapped<std::uint64_t>(p) : load<std::uint64_t>(p));
    case Scalar::kF32: return big_endian ? load_swapped<float>(p) : load<float>(p);
    case Scalar::kF64: return big_endian ? load_swapped<double>(p) : load<double>(p);
  }
  return 0.0;
}

template <typename T>
  requires std::is_arithmetic_v<T>
void append(std::vector<std::uint8_t>& out, T value) {
  std::uint8_t b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  out.insert(out.end(), b, b + sizeof(T));
}

inline void append_text(std::vector<std::uint8_t>& out, std::string_view text) {
  out.insert(out.end(), text.begin(), text.end());
}

// The shortest text that reads back to the same value (to_chars; 32 characters suffice).
template <typename T>
  requires std::is_floating_point_v<T>
void append_float(std::vector<std::uint8_t>& out, T v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof(buf), v);
  (void)ec;
  out.insert(out.end(), buf, end);
}

// Next '\n'-terminated line starting at pos (without "\r\n"); false at the end of the buffer.
inline bool next_line(std::span<const std::uint8_t> bytes, std::size_t& pos, std::string_view& line) {
  if (pos >= bytes.size()) return false;
  const char* begin = reinterpret_cast<const char*>(bytes.data()) + pos;
  const void* nl = std::memchr(begin, '\n', bytes.size() - pos);
  std::size_t len = nl ? static_cast<std::size_t>(static_cast<const char*>(nl) - begin)
                       : bytes.size() - pos;
  pos += len + (nl ? 1 : 0);
  if (len > 0 && begin[len - 1] == '\r') --len;
  line = std::string_view(begin, len);
  return true;
}

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Splits on blanks into `tokens` (cleared); returns the token count.
inline std::size_t split(std::string_view line, std::vector<std::string_view>& tokens) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens.size();
}

// Parses a whole token as a number (accepts a leading '+', nan, inf).
template <typename T>
bool parse_number(std::string_view token, T& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && ptr == token.data() + token.size();
}

inline std::string to_lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return r;
}

// Counts non-finite points and, if asked, removes them together with their attributes.
void finish_cloud(PointCloud& cloud, const ReadOptions& options, ReadStats* stats);

}  // namespace v2xloc::cloud_io::detail
