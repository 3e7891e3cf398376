#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/cloud_io/detail.hpp"

namespace v2xloc::cloud_io {

namespace {
constexpr std::size_t kRecordBytes = 16;  // float32 x, y, z, intensity
}

bool parse_kitti_bin(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
                     const ReadOptions& options, ReadStats* stats) {
  out.clear();
  if (bytes.size() % kRecordBytes != 0) {
    error = "KITTI .bin size " + std::to_string(bytes.size()) + " is not a multiple of 16 bytes";
    return false;
  }
  const std::size_t n = bytes.size() / kRecordBytes;
  if (n > options.max_points) {
    error = std::to_string(n) + " points exceed the limit of " + std::to_string(options.max_points);
    return false;
  }
  out.points.resize(n);
  out.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p = bytes.data() + i * kRecordBytes;
    out.points[i] = Eigen::Vector3f(detail::load<float>(p), detail::load<float>(p + 4),
                                    detail::load<float>(p + 8));
    out.intensity[i] = detail::load<float>(p + 12);
  }
  out.width = static_cast<std::uint32_t>(n);
  out.height = 1;
  if (stats != nullptr) stats->skipped_fields.clear();
  detail::finish_cloud(out, options, stats);
  return true;
}

bool read_kitti_bin(const std::string& path, PointCloud& out, std::string& error,
                    const ReadOptions& options, ReadStats* stats) {
  std::vector<std::uint8_t> bytes;
  if (!read_file_bytes(path, bytes, error)) return false;
  if (!parse_kitti_bin(bytes, out, error, options, stats)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

bool encode_kitti_bin(const PointCloud& cloud, std::vector<std::uint8_t>& out, std::string& error) {
  out.clear();
  if (!cloud.consistent()) {
    error = "point cloud attributes do not have one entry per point";
    return false;
  }
  out.reserve(cloud.size() * kRecordBytes);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) detail::append(out, cloud.points[i][a]);
    detail::append(out, cloud.has_intensity() ? cloud.intensity[i] : 0.0f);
  }
  return true;
}

bool write_kitti_bin(const std::string& path, const PointCloud& cloud, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!encode_kitti_bin(cloud, bytes, error)) {
    error = path + ": " + error;
    return false;
  }
  return write_file_bytes(path, bytes, error);
}

}  // namespace v2xloc::cloud_io
