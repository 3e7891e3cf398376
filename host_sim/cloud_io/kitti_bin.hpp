// KITTI Velodyne .bin: headerless little-endian float32 records (x, y, z, intensity).
// A size that is not a multiple of 16 bytes is an error. Writing without intensity writes 0.
#pragma once

#include "host_sim/cloud_io/point_cloud.hpp"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace v2xloc::cloud_io {

bool read_kitti_bin(const std::string& path, PointCloud& out, std::string& error,
                    const ReadOptions& options = {}, ReadStats* stats = nullptr);
bool parse_kitti_bin(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
                     const ReadOptions& options = {}, ReadStats* stats = nullptr);

bool write_kitti_bin(const std::string& path, const PointCloud& cloud, std::string& error);
bool encode_kitti_bin(const PointCloud& cloud, std::vector<std::uint8_t>& out, std::string& error);

}  // namespace v2xloc::cloud_io
