// Whole-file text I/O for host tools: writes report a reason, reads refuse files above a size cap
// (a recording's metadata is kilobytes; a multi-gigabyte "manifest" is an attack, not a manifest).
#pragma once

#include <cstddef>
#include <string>

namespace v2xloc::sim {

bool write_text_file(const std::string& path, const std::string& text, std::string& error);
bool read_text_file(const std::string& path, std::size_t max_bytes, std::string& out, std::string& error);

}  // namespace v2xloc::sim
