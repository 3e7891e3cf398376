// PCD (PCL's point cloud format, v0.7): DATA ascii, binary and binary_compressed (LZF), and our
// quantised variant (DATA binary_shuffled_zlib with a SCALE line, below; extension .pcdz).
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

// Quantised clouds (recording format 2, extension .pcdz): the PCD header plus a SCALE line (value =
// stored integer x scale, one per field), fields x y z as int32, intensity as uint8, t as uint32,
// DATA binary_shuffled_zlib: <u32 compressed size><u32 raw size><zlib stream>, whose raw bytes are
// struct-of-arrays like binary_compressed with each field's block split into byte planes (byte 0
// of every value, then byte 1, ...), so the nearly constant high bytes compress away.
// PCL and Open3D do not read it (they stop at the unknown DATA type); write_pcd exports a standard
// file. parse_pcd/read_pcd read it like any PCD.
struct Quantisation {
  double xyz_step_m = 0.001;              // int32 multiples
  double intensity_step = 1.0 / 255.0;    // uint8 multiples: intensity in [0, 1]
  double time_step_s = 1e-9;              // uint32 multiples: 0 <= t < 4.29 s
};
// False with a message when a value does not fit its integer (non-finite, out of range) or the
// cloud has normals (not part of this encoding).
bool encode_quantised_pcd(const PointCloud& cloud, const Quantisation& q, std::vector<std::uint8_t>& out,
                          std::string& error);
bool write_quantised_pcd(const std::string& path, const PointCloud& cloud, const Quantisation& q,
                         std::string& error);

// zlib blocks (level 6) and byte planes of binary_shuffled_zlib. zlib_decompress returns the bytes
// written, or 0 unless the stream is valid, ends exactly at the end of `in` and fits `out`.
bool zlib_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);
std::size_t zlib_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);
// `in` holds n values of `width` bytes; out[k * n + i] = byte k of value i. Same sizes.
void shuffle_bytes(std::span<const std::uint8_t> in, std::size_t width, std::span<std::uint8_t> out);

// LZF blocks as PCL's binary_compressed stores them, through the system liblzf. Returns the number
// of bytes written to `out`, or 0 on corrupt input / output overflow / empty input.
std::size_t lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);
// Compresses into `out` (cleared first); false only for blocks liblzf cannot address (>= 4 GiB).
bool lzf_compress(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out);

}  // namespace v2xloc::cloud_io
