// PCD (PCL's point cloud format, v0.7): DATA ascii, binary and binary_compressed (LZF).
// Readers accept any field order, F4/F8 coordinates, integer and float attributes, COUNT > 1 and
// padding ("_") fields; fields we do not know (rgb, ring, ...) are skipped. Writers produce exactly
// the header PCL writes (comment line, VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT,
// VIEWPOINT, POINTS, DATA) with fields x y z [intensity] [t] [normal_x normal_y normal_z].
// All functions return false with a one-line message in `error` on malformed input; bounds are
// checked everywhere (truncated files, headers that lie, absurd counts), nothing throws.
#pragma once

#include "host_sim/cloud_io/point_cloud.hpp"

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace v2xloc::cloud_io {

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

bool read_pcd(const std::string& path, PointCloud& out, std::string& error,
              const ReadOptions& options = {}, ReadStats* stats = nullptr);
bool parse_pcd(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
               const ReadOptions& options = {}, ReadStats* stats = nullptr);

bool write_pcd(const std::string& path, const PointCloud& cloud, PcdEncoding encoding,
               std::string& error);
bool encode_pcd(const PointCloud& cloud, PcdEncoding encoding, std::vector<std::uint8_t>& out,
                std::string& error);

// LZF blocks as PCL's binary_compressed stores them, through the system liblzf. Returns the number
// of bytes written to `out`, or 0 on corrupt input / output overflow / empty input.
std::size_t lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);
// Compresses into `out` (cleared first); false only for blocks liblzf cannot address (>= 4 GiB).
bool lzf_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);

}  // namespace v2xloc::cloud_io
