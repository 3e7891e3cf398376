// libFuzzer target: every reader on arbitrary bytes must return (true, consistent cloud) or
// (false, message), never crash or read out of bounds (run with ASan). First byte picks the reader.
#include "host_sim/cloud_io/cloud_io.hpp"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  using namespace v2xloc::cloud_io;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  PointCloud cloud;
  std::string error;
  ReadOptions options;
  options.max_points = 1 << 20;
  bool ok = false;
  switch (data[0] % 4) {
    case 0: ok = parse_pcd(bytes, cloud, error, options); break;
    case 1: ok = parse_ply(bytes, cloud, error, options); break;
    case 2: ok = parse_kitti_bin(bytes, cloud, error, options); break;
    default: {
      std::vector<std::uint8_t> out(4096);
      (void)lzf_decompress(bytes, out);
      return 0;
    }
  }
  if (ok ? !cloud.consistent() : error.empty()) std::abort();
  return 0;
}
