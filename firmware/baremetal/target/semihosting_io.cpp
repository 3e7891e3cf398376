#include "firmware/baremetal/target/semihosting_io.hpp"

#include <cstdio>

namespace v2xloc::target {
namespace {

std::FILE* g_in = nullptr;
std::FILE* g_out = nullptr;

class FileSource final : public v2xloc::fixture::ByteSource {
 public:
  bool read(void* dst, std::size_t n) override { return std::fread(dst, 1, n, g_in) == n; }
};
FileSource g_source;

}  // namespace

bool open_files(const char* fixture_path, const char* output_path) {
  g_in = std::fopen(fixture_path, "rb");
  g_out = std::fopen(output_path, "w");
  if (g_in == nullptr || g_out == nullptr) std::puts("v2xloc target: cannot open the fixture or the output");
  return g_in != nullptr && g_out != nullptr;
}

v2xloc::fixture::ByteSource& fixture_source() { return g_source; }

void write_output(const char* text) { std::fputs(text, g_out); }

void print(const char* text) { std::fputs(text, stdout); }

bool close_files() {
  const bool in_ok = std::fclose(g_in) == 0;
  return std::fclose(g_out) == 0 && in_ok;
}

}  // namespace v2xloc::target
