#include "host_sim/recording/pcd_export.hpp"

#include "host_sim/cloud_io/point_cloud.hpp"

#include <filesystem>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

// The manifest path (already checked to stay inside the recording) with the extension .pcd.
fs::path pcd_path(const std::string& out_dir, const std::string& rel) {
  fs::path p = fs::path(out_dir) / rel;
  p.replace_extension(".pcd");
  return p;
}

bool write_one(const cloud_io::PointCloud& cloud, const fs::path& path, cloud_io::PcdEncoding encoding,
               PcdExportSummary& summary, std::string& error) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) {
    error = "cannot create " + path.parent_path().string() + ": " + ec.message();
    return false;
  }
  if (!cloud_io::write_pcd(path.string(), cloud, encoding, error)) return false;
  summary.bytes += fs::file_size(path, ec);
  ++summary.clouds;
  return true;
}

}  // namespace

bool export_recording_pcd(const RecordingReader& reader, const std::string& out_dir, cloud_io::PcdEncoding encoding,
                          PcdExportSummary& summary, std::string& error, const std::function<void(int, int)>& progress) {
  summary = PcdExportSummary{};
  const int total = reader.frame_count() + static_cast<int>(reader.map_clouds().size());
  RecordingReader::IndexPattern scans;
  scans.prefix = "ego_lidar/";
  scans.suffix = ".pcd";
  scans.width = 6;
  cloud_io::PointCloud cloud;
  for (int i = 0; i < reader.frame_count(); ++i) {
    if (!reader.ego_scan(i, cloud, error) ||
        !write_one(cloud, pcd_path(out_dir, scans.format(i)), encoding, summary, error))
      return false;
    if (progress) progress(summary.clouds, total);
  }
  for (const MapCloudInfo& info : reader.map_clouds()) {
    if (!reader.load_map_cloud(info, cloud, error) ||
        !write_one(cloud, pcd_path(out_dir, info.file), encoding, summary, error))
      return false;
    if (progress) progress(summary.clouds, total);
  }
  return true;
}

}  // namespace v2xloc::sim
