// PCD (ascii, binary, binary_compressed through liblzf, binary_shuffled_zlib) from arbitrary bytes.
#include "tests/fuzz/cloud_check.hpp"

namespace {
bool encode_binary(const v2xloc::cloud_io::PointCloud& c, std::vector<std::uint8_t>& out, std::string& error) {
  return v2xloc::cloud_io::encode_pcd(c, v2xloc::cloud_io::PcdEncoding::kBinaryCompressed, out, error);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  v2xloc::fuzz::check_reader(data, size, v2xloc::cloud_io::parse_pcd, encode_binary);
  return 0;
}
