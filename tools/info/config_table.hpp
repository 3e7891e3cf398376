// Every constant of algo's config.hpp as a runtime table (generated at build time).
#pragma once

#include <cstdint>
#include <span>
#include <type_traits>

namespace v2xloc::tools {

struct ConfigEntry {
  const char* section;   // the "// ---- Section ----" heading above it
  const char* name;      // e.g. "kMaxScanPoints"
  double value;          // integers up to 2^53 exactly; bool as 0/1
  const char* comment;   // trailing comment on its line, if any
};

template <typename T>
constexpr double integral_value(T v) {
  static_assert(std::is_arithmetic_v<T>, "config constants are numbers or bools");
  return static_cast<double>(v);
}

std::span<const ConfigEntry> config_entries();

}  // namespace v2xloc::tools
