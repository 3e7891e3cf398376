// KITTI .bin (x y z intensity float32 records) from arbitrary bytes.
#include "tests/fuzz/cloud_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  v2xloc::fuzz::check_reader(data, size, v2xloc::cloud_io::parse_kitti_bin, v2xloc::cloud_io::encode_kitti_bin);
  return 0;
}
