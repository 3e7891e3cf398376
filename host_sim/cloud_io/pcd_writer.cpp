// PCD writer producing the header PCL's PCDWriter generates (pcl/io/pcd_io.cpp generateHeader):
// comment line, VERSION 0.7, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS, DATA.
// All fields are F4. ASCII values use the shortest text that reads back to the same float.
#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/cloud_io/detail.hpp"

#include <charconv>

namespace v2xloc::cloud_io {
namespace {

using detail::append_float;

std::vector<std::string> field_names(const PointCloud& c) {
  std::vector<std::string> names = {"x", "y", "z"};
  if (c.has_intensity()) names.push_back("intensity");
  if (c.has_time()) names.push_back("t");
  if (c.has_normals()) {
    names.push_back("normal_x");
    names.push_back("normal_y");
    names.push_back("normal_z");
  }
  return names;
}

// Point i's values in field_names() order.
std::size_t point_values(const PointCloud& c, std::size_t i, float* v) {
  std::size_t k = 0;
  v[k++] = c.points[i].x();
  v[k++] = c.points[i].y();
  v[k++] = c.points[i].z();
  if (c.has_intensity()) v[k++] = c.intensity[i];
  if (c.has_time()) v[k++] = c.time[i];
  if (c.has_normals()) {
    v[k++] = c.normals[i].x();
    v[k++] = c.normals[i].y();
    v[k++] = c.normals[i].z();
  }
  return k;
}

void append_header(const PointCloud& c, const std::vector<std::string>& names, const char* data,
                   std::vector<std::uint8_t>& out) {
  const std::size_t n = c.size();
  const bool organized = c.height > 1 && std::size_t{c.width} * c.height == n;
  std::string h = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const std::string& name : names) h += " " + name;
  h += "\nSIZE";
  for (std::size_t i = 0; i < names.size(); ++i) h += " 4";
  h += "\nTYPE";
  for (std::size_t i = 0; i < names.size(); ++i) h += " F";
  h += "\nCOUNT";
  for (std::size_t i = 0; i < names.size(); ++i) h += " 1";
  h += "\nWIDTH " + std::to_string(organized ? c.width : n);
  h += "\nHEIGHT " + std::to_string(organized ? c.height : 1u);
  h += "\nVIEWPOINT";
  detail::append_text(out, h);
  const Eigen::Quaternionf& q = c.sensor_orientation;
  for (float v : {c.sensor_origin.x(), c.sensor_origin.y(), c.sensor_origin.z(), q.w(), q.x(), q.y(), q.z()}) {
    out.push_back(' ');
    append_float(out, v);
  }
  detail::append_text(out, "\nPOINTS " + std::to_string(n) + "\nDATA " + data + "\n");
}

}  // namespace

bool encode_pcd(const PointCloud& cloud, PcdEncoding encoding, std::vector<std::uint8_t>& out,
                std::string& error) {
  out.clear();
  if (!cloud.consistent()) {
    error = "point cloud attributes do not have one entry per point";
    return false;
  }
  const std::vector<std::string> names = field_names(cloud);
  const std::size_t n = cloud.size();
  const std::size_t nf = names.size();
  float v[8];
  switch (encoding) {
    case PcdEncoding::kAscii: {
      append_header(cloud, names, "ascii", out);
      out.reserve(out.size() + n * nf * 12);
      for (std::size_t i = 0; i < n; ++i) {
        point_values(cloud, i, v);
        for (std::size_t k = 0; k < nf; ++k) {
          if (k > 0) out.push_back(' ');
          append_float(out, v[k]);
        }
        out.push_back('\n');
      }
      return true;
    }
    case PcdEncoding::kBinary: {
      append_header(cloud, names, "binary", out);
      out.reserve(out.size() + n * nf * 4);
      for (std::size_t i = 0; i < n; ++i) {
        point_values(cloud, i, v);
        for (std::size_t k = 0; k < nf; ++k) detail::append(out, v[k]);
      }
      return true;
    }
    case PcdEncoding::kBinaryCompressed: {
      append_header(cloud, names, "binary_compressed", out);
      // Struct-of-arrays: every field's values contiguous (compresses far better than AoS).
      std::vector<std::uint8_t> soa;
      soa.reserve(n * nf * 4);
      for (std::size_t k = 0; k < nf; ++k) {
        for (std::size_t i = 0; i < n; ++i) {
          point_values(cloud, i, v);
          detail::append(soa, v[k]);
        }
      }
      std::vector<std::uint8_t> packed;
      if (soa.size() > 0xffffffffu || !lzf_compress(soa, packed) || packed.size() > 0xffffffffu) {
        error = "cloud too large for binary_compressed (4 GiB block limit)";
        out.clear();
        return false;
      }
      detail::append(out, static_cast<std::uint32_t>(packed.size()));
      detail::append(out, static_cast<std::uint32_t>(soa.size()));
      out.insert(out.end(), packed.begin(), packed.end());
      return true;
    }
  }
  error = "unknown PCD encoding";
  return false;
}

bool write_pcd(const std::string& path, const PointCloud& cloud, PcdEncoding encoding,
               std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!encode_pcd(cloud, encoding, bytes, error)) {
    error = path + ": " + error;
    return false;
  }
  return write_file_bytes(path, bytes, error);
}

}  // namespace v2xloc::cloud_io
