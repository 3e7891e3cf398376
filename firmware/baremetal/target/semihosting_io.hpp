// The target image's host I/O over semihosting (newlib rdimon stdio), the one part of the image
// that allocates (stdio's FILE buffers): kept in its own object so that the link-map check
// (tools/target/check_target_heap.py) can prove nothing else reaches the heap.
#pragma once

#include <cstddef>

#include "firmware/fixture/fixture_player.hpp"

namespace v2xloc::target {

// The fixture to read and the output to write; false (after saying why) if either fails to open.
bool open_files(const char* fixture_path, const char* output_path);
v2xloc::fixture::ByteSource& fixture_source();
void write_output(const char* text);
void print(const char* text);  // QEMU's standard output
bool close_files();

}  // namespace v2xloc::target
