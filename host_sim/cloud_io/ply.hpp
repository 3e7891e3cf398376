// PLY: reads ascii and binary_little_endian (binary_big_endian too); the "vertex" element's x y z
// (float/double/any int type) plus optional intensity / scalar_intensity, nx ny nz (or normal_x..),
// t / time; list properties and other elements are skipped. Writes binary_little_endian with float
// properties x y z [intensity] [t] [nx ny nz]. Bounds-checked, never throws.
#pragma once

#include "host_sim/cloud_io/point_cloud.hpp"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace v2xloc::cloud_io {

bool read_ply(const std::string& path, PointCloud& out, std::string& error,
              const ReadOptions& options = {}, ReadStats* stats = nullptr);
bool parse_ply(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
               const ReadOptions& options = {}, ReadStats* stats = nullptr);

bool write_ply(const std::string& path, const PointCloud& cloud, std::string& error);
bool encode_ply(const PointCloud& cloud, std::vector<std::uint8_t>& out, std::string& error);

}  // namespace v2xloc::cloud_io
