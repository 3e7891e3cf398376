// PLY (ascii, binary little/big endian, elements before "vertex", list properties).
#include "tests/fuzz/cloud_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  v2xloc::fuzz::check_reader(data, size, v2xloc::cloud_io::parse_ply, v2xloc::cloud_io::encode_ply);
  return 0;
}
