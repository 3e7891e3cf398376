// Writer of quantised clouds (pcd.hpp: SCALE line, DATA binary_shuffled_zlib), the storage of
// recording format 2: ~4 bytes per point instead of ~16 for float32 binary_compressed.
#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/cloud_io/detail.hpp"

#include <cmath>
#include <limits>

namespace v2xloc::cloud_io {
namespace {

// round(value / step) as T, or false when it is not finite or outside T's range.
template <typename T>
bool quantise(double value, double step, T& out) {
  const double q = std::round(value / step);
  if (!std::isfinite(q) || q < static_cast<double>(std::numeric_limits<T>::min()) ||
      q > static_cast<double>(std::numeric_limits<T>::max()))
    return false;
  out = static_cast<T>(q);
  return true;
}

// Appends one field's block: the quantised values, split into byte planes.
template <typename T, typename Get>
bool append_field(std::size_t n, double step, Get&& get, const char* name, std::vector<std::uint8_t>& soa,
                  std::string& error) {
  std::vector<std::uint8_t> block;
  block.reserve(n * sizeof(T));
  for (std::size_t i = 0; i < n; ++i) {
    T v{};
    if (!quantise(static_cast<double>(get(i)), step, v)) {
      error = std::string("point ") + std::to_string(i) + ": " + name + " = " + std::to_string(get(i)) +
              " does not fit the quantised encoding (step " + std::to_string(step) + ")";
      return false;
    }
    detail::append(block, v);
  }
  const std::size_t start = soa.size();
  soa.resize(start + block.size());
  shuffle_bytes(block, sizeof(T), std::span<std::uint8_t>(soa.data() + start, block.size()));
  return true;
}

struct FieldSpec {
  const char* name;
  int size;
  char type;
  double scale;
};

void append_header(const PointCloud& c, const std::vector<FieldSpec>& fields, std::vector<std::uint8_t>& out) {
  const std::size_t n = c.size();
  const bool organized = c.height > 1 && std::size_t{c.width} * c.height == n;
  std::string h =
      "# v2xloc quantised cloud: PCD v0.7 header + SCALE, DATA binary_shuffled_zlib (PCL/Open3D do not read it;"
      " v2xloc-sim export-pcd writes standard PCD)\nVERSION 0.7\nFIELDS";
  for (const FieldSpec& f : fields) h += std::string(" ") + f.name;
  h += "\nSIZE";
  for (const FieldSpec& f : fields) h += " " + std::to_string(f.size);
  h += "\nTYPE";
  for (const FieldSpec& f : fields) h += std::string(" ") + f.type;
  h += "\nCOUNT";
  for (std::size_t i = 0; i < fields.size(); ++i) h += " 1";
  h += "\nSCALE";
  detail::append_text(out, h);
  for (const FieldSpec& f : fields) {
    out.push_back(' ');
    detail::append_float(out, f.scale);
  }
  h = "\nWIDTH " + std::to_string(organized ? c.width : n);
  h += "\nHEIGHT " + std::to_string(organized ? c.height : 1u);
  h += "\nVIEWPOINT";
  detail::append_text(out, h);
  const Eigen::Quaternionf& q = c.sensor_orientation;
  for (float v : {c.sensor_origin.x(), c.sensor_origin.y(), c.sensor_origin.z(), q.w(), q.x(), q.y(), q.z()}) {
    out.push_back(' ');
    detail::append_float(out, v);
  }
  detail::append_text(out, "\nPOINTS " + std::to_string(n) + "\nDATA binary_shuffled_zlib\n");
}

}  // namespace

bool encode_quantised_pcd(const PointCloud& cloud, const Quantisation& q, std::vector<std::uint8_t>& out,
                          std::string& error) {
  out.clear();
  if (!cloud.consistent()) {
    error = "point cloud attributes do not have one entry per point";
    return false;
  }
  if (cloud.has_normals()) {
    error = "the quantised encoding has no normals";
    return false;
  }
  for (double step : {q.xyz_step_m, q.intensity_step, q.time_step_s}) {
    if (!(step > 0.0) || !std::isfinite(step)) {
      error = "quantisation steps must be finite and positive";
      return false;
    }
  }
  const std::size_t n = cloud.size();
  std::vector<FieldSpec> fields = {{"x", 4, 'I', q.xyz_step_m}, {"y", 4, 'I', q.xyz_step_m}, {"z", 4, 'I', q.xyz_step_m}};
  std::vector<std::uint8_t> soa;
  soa.reserve(n * 17);
  const char* axis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    if (!append_field<std::int32_t>(n, q.xyz_step_m, [&](std::size_t i) { return cloud.points[i][k]; }, axis[k], soa,
                                    error))
      return false;
  }
  if (cloud.has_intensity()) {
    fields.push_back({"intensity", 1, 'U', q.intensity_step});
    if (!append_field<std::uint8_t>(n, q.intensity_step, [&](std::size_t i) { return cloud.intensity[i]; }, "intensity",
                                    soa, error))
      return false;
  }
  if (cloud.has_time()) {
    fields.push_back({"t", 4, 'U', q.time_step_s});
    if (!append_field<std::uint32_t>(n, q.time_step_s, [&](std::size_t i) { return cloud.time[i]; }, "t", soa, error))
      return false;
  }
  std::vector<std::uint8_t> packed;
  if (soa.size() > 0xffffffffu || !zlib_compress(soa, packed) || packed.size() > 0xffffffffu) {
    error = "cloud too large for binary_shuffled_zlib (4 GiB block limit)";
    return false;
  }
  append_header(cloud, fields, out);
  detail::append(out, static_cast<std::uint32_t>(packed.size()));
  detail::append(out, static_cast<std::uint32_t>(soa.size()));
  out.insert(out.end(), packed.begin(), packed.end());
  return true;
}

bool write_quantised_pcd(const std::string& path, const PointCloud& cloud, const Quantisation& q,
                         std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!encode_quantised_pcd(cloud, q, bytes, error)) {
    error = path + ": " + error;
    return false;
  }
  return write_file_bytes(path, bytes, error);
}

}  // namespace v2xloc::cloud_io
