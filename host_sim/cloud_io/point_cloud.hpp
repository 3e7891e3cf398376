// Host-side point cloud container shared by the simulator (writes recordings), the tools and the
// tests (read them). Attributes other than xyz are optional: an empty vector means "absent",
// otherwise it has exactly points.size() entries.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace v2xloc::cloud_io {

struct PointCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;           // PCD "intensity", PLY intensity / scalar_intensity
  std::vector<float> time;                // per-point time [s], relative to the scan's stamp (PCD "t")
  std::vector<Eigen::Vector3f> normals;   // PCD/PLY normal_x.. / nx..

  // Organized clouds (PCD WIDTH x HEIGHT). height == 1 (or width*height != size) -> unorganized.
  std::uint32_t width = 0;
  std::uint32_t height = 1;

  // Sensor pose in the cloud's frame (PCD VIEWPOINT tx ty tz qw qx qy qz); identity if absent.
  bool has_viewpoint = false;
  Eigen::Vector3f sensor_origin = Eigen::Vector3f::Zero();
  Eigen::Quaternionf sensor_orientation = Eigen::Quaternionf::Identity();

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
  bool has_intensity() const { return !intensity.empty(); }
  bool has_time() const { return !time.empty(); }
  bool has_normals() const { return !normals.empty(); }
  void clear() { *this = PointCloud{}; }
  // True when every present attribute has one entry per point (writers check this).
  bool consistent() const;
};

struct ReadOptions {
  // Drop points with a NaN/Inf coordinate (PCL organized clouds contain them). Off by default:
  // the algorithm core drops and counts them itself. Counted in ReadStats either way.
  bool drop_non_finite = false;
  // Headers claiming more points than this are rejected before anything is allocated.
  std::size_t max_points = 50'000'000;
  // [s] subtracted from every per-point time in double before it is stored as float: a sensor's
  // absolute stamps (a `timestamp` field in unix seconds) become times since the scan's stamp.
  double time_offset_s = 0.0;
};

struct ReadStats {
  std::size_t non_finite = 0;        // points with a NaN/Inf coordinate (kept or dropped)
  std::size_t dropped = 0;           // points not returned (drop_non_finite)
  std::vector<std::string> skipped_fields;  // fields/properties we do not interpret (rgb, ...)
};

}  // namespace v2xloc::cloud_io
