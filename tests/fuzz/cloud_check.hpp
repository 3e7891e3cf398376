// Shared property of the point-cloud fuzz targets: a reader returns either a consistent cloud that
// its own writer can encode and read back with the same point count, or false with a message.
// Anything else (crash, sanitizer report, abort) is a finding.
#pragma once

#include "host_sim/cloud_io/cloud_io.hpp"

#include <cstdlib>

namespace v2xloc::fuzz {

using ParseFn = bool (*)(std::span<const std::uint8_t>, cloud_io::PointCloud&, std::string&,
                         const cloud_io::ReadOptions&, cloud_io::ReadStats*);
using EncodeFn = bool (*)(const cloud_io::PointCloud&, std::vector<std::uint8_t>&, std::string&);

inline void check_reader(const std::uint8_t* data, std::size_t size, ParseFn parse, EncodeFn encode) {
  cloud_io::ReadOptions options;
  options.max_points = 1 << 20;  // the fuzzer's RSS limit, not the readers', bounds the inputs
  cloud_io::PointCloud cloud;
  std::string error;
  if (!parse({data, size}, cloud, error, options, nullptr)) {
    if (error.empty()) std::abort();
    return;
  }
  if (!cloud.consistent()) std::abort();
  std::vector<std::uint8_t> bytes;
  cloud_io::PointCloud back;
  if (!encode(cloud, bytes, error) || !parse(bytes, back, error, options, nullptr) || back.size() != cloud.size())
    std::abort();
}

}  // namespace v2xloc::fuzz
