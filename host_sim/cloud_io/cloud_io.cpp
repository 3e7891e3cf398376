#include "host_sim/cloud_io/cloud_io.hpp"

#include "host_sim/cloud_io/detail.hpp"

#include <cmath>
#include <cstdio>
#include <memory>

namespace v2xloc::cloud_io {

bool PointCloud::consistent() const {
  const std::size_t n = points.size();
  return (intensity.empty() || intensity.size() == n) && (time.empty() || time.size() == n) &&
         (normals.empty() || normals.size() == n);
}

namespace detail {

void finish_cloud(PointCloud& cloud, const ReadOptions& options, ReadStats* stats) {
  std::size_t non_finite = 0;
  for (const Eigen::Vector3f& p : cloud.points) non_finite += p.allFinite() ? 0 : 1;
  std::size_t dropped = 0;
  if (options.drop_non_finite && non_finite > 0) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      if (!cloud.points[i].allFinite()) continue;
      cloud.points[kept] = cloud.points[i];
      if (cloud.has_intensity()) cloud.intensity[kept] = cloud.intensity[i];
      if (cloud.has_time()) cloud.time[kept] = cloud.time[i];
      if (cloud.has_normals()) cloud.normals[kept] = cloud.normals[i];
      ++kept;
    }
    dropped = cloud.points.size() - kept;
    cloud.points.resize(kept);
    if (cloud.has_intensity()) cloud.intensity.resize(kept);
    if (cloud.has_time()) cloud.time.resize(kept);
    if (cloud.has_normals()) cloud.normals.resize(kept);
    cloud.width = static_cast<std::uint32_t>(kept);  // no longer organized
    cloud.height = 1;
  }
  if (stats != nullptr) {
    stats->non_finite = non_finite;
    stats->dropped = dropped;
  }
}

}  // namespace detail

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

std::string extension_of(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  return detail::to_lower(std::string_view(path).substr(dot + 1));
}

}  // namespace

bool read_file_bytes(const std::string& path, std::vector<std::uint8_t>& out, std::string& error,
                     std::size_t max_bytes) {
  out.clear();
  File f(std::fopen(path.c_str(), "rb"));
  if (!f) {
    error = "cannot open '" + path + "' for reading";
    return false;
  }
  std::uint8_t chunk[1 << 16];
  while (true) {
    const std::size_t n = std::fread(chunk, 1, sizeof(chunk), f.get());
    if (n > 0) {
      if (out.size() + n > max_bytes) {
        error = "'" + path + "' is larger than " + std::to_string(max_bytes) + " bytes";
        out.clear();
        return false;
      }
      out.insert(out.end(), chunk, chunk + n);
    }
    if (n < sizeof(chunk)) break;
  }
  if (std::ferror(f.get())) {
    error = "read error on '" + path + "'";
    out.clear();
    return false;
  }
  return true;
}

bool write_file_bytes(const std::string& path, std::span<const std::uint8_t> bytes,
                      std::string& error) {
  File f(std::fopen(path.c_str(), "wb"));
  if (!f) {
    error = "cannot open '" + path + "' for writing";
    return false;
  }
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), f.get()) != bytes.size()) {
    error = "write error on '" + path + "'";
    return false;
  }
  if (std::fclose(f.release()) != 0) {
    error = "cannot close '" + path + "'";
    return false;
  }
  return true;
}

bool read_cloud(const std::string& path, PointCloud& out, std::string& error,
                const ReadOptions& options, ReadStats* stats) {
  const std::string ext = extension_of(path);
  if (ext == "pcd" || ext == "pcdz") return read_pcd(path, out, error, options, stats);
  if (ext == "ply") return read_ply(path, out, error, options, stats);
  if (ext == "bin") return read_kitti_bin(path, out, error, options, stats);
  error = "unknown point cloud extension in '" + path + "' (expected .pcd, .pcdz, .ply or .bin)";
  return false;
}

bool write_cloud(const std::string& path, const PointCloud& cloud, std::string& error) {
  const std::string ext = extension_of(path);
  if (ext == "pcd") return write_pcd(path, cloud, PcdEncoding::kBinary, error);
  if (ext == "pcdz") return write_quantised_pcd(path, cloud, Quantisation{}, error);
  if (ext == "ply") return write_ply(path, cloud, error);
  if (ext == "bin") return write_kitti_bin(path, cloud, error);
  error = "unknown point cloud extension in '" + path + "' (expected .pcd, .pcdz, .ply or .bin)";
  return false;
}

}  // namespace v2xloc::cloud_io
