// Point cloud I/O for host code: PCD, quantised PCD, PLY and KITTI .bin, chosen by file extension
// (.pcd, .pcdz, .ply, .bin; case-insensitive). Link v2xloc_cloud_io, include "host_sim/cloud_io/cloud_io.hpp".
#pragma once

#include "host_sim/cloud_io/kitti_bin.hpp"
#include "host_sim/cloud_io/pcd.hpp"
#include "host_sim/cloud_io/ply.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"

#include <string>

namespace v2xloc::cloud_io {

bool read_cloud(const std::string& path, PointCloud& out, std::string& error,
                const ReadOptions& options = {}, ReadStats* stats = nullptr);
// .pcd is written as binary (PCL's default for recordings; write_pcd for ascii), .pcdz quantised
// with the default steps (1 mm, 1/255, 1 ns).
bool write_cloud(const std::string& path, const PointCloud& cloud, std::string& error);

// Whole-file helpers (bounded by max_bytes; false with a message on failure).
bool read_file_bytes(const std::string& path, std::vector<std::uint8_t>& out, std::string& error,
                     std::size_t max_bytes = std::size_t{4} << 30);
bool write_file_bytes(const std::string& path, std::span<const std::uint8_t> bytes,
                      std::string& error);

}  // namespace v2xloc::cloud_io
