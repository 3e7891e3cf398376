// PLY (Turk 1994; the format of paulbourke.net/dataformats/ply). Only the "vertex" element is
// decoded; elements before it are skipped instance by instance (their lists have per-instance
// lengths), elements after it are ignored.
#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/cloud_io/detail.hpp"

#include <limits>

namespace v2xloc::cloud_io {
namespace {

using detail::Scalar;

enum class Format { kAscii, kBinaryLE, kBinaryBE };
enum Role : int { kX, kY, kZ, kIntensity, kTime, kNx, kNy, kNz, kRoleCount };

struct Property {
  std::string name;
  Scalar type = Scalar::kF32;
  bool is_list = false;
  Scalar count_type = Scalar::kU8;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

bool scalar_of(std::string_view name, Scalar& s) {
  const std::string n = detail::to_lower(name);
  if (n == "char" || n == "int8") s = Scalar::kI8;
  else if (n == "uchar" || n == "uint8") s = Scalar::kU8;
  else if (n == "short" || n == "int16") s = Scalar::kI16;
  else if (n == "ushort" || n == "uint16") s = Scalar::kU16;
  else if (n == "int" || n == "int32") s = Scalar::kI32;
  else if (n == "uint" || n == "uint32") s = Scalar::kU32;
  else if (n == "float" || n == "float32") s = Scalar::kF32;
  else if (n == "double" || n == "float64") s = Scalar::kF64;
  else return false;
  return true;
}

int role_of(const std::string& lower_name) {
  if (lower_name == "x") return kX;
  if (lower_name == "y") return kY;
  if (lower_name == "z") return kZ;
  if (lower_name == "intensity" || lower_name == "scalar_intensity") return kIntensity;
  if (lower_name == "t" || lower_name == "time") return kTime;
  if (lower_name == "nx" || lower_name == "normal_x") return kNx;
  if (lower_name == "ny" || lower_name == "normal_y") return kNy;
  if (lower_name == "nz" || lower_name == "normal_z") return kNz;
  return -1;
}

bool parse_header(std::span<const std::uint8_t> bytes, Format& format, std::vector<Element>& elements,
                  std::size_t& data_offset, std::string& error) {
  std::size_t pos = 0;
  std::string_view line;
  std::vector<std::string_view> tokens;
  if (!detail::next_line(bytes, pos, line) || detail::split(line, tokens) != 1 || tokens[0] != "ply") {
    error = "not a PLY file (first line is not 'ply')";
    return false;
  }
  bool has_format = false;
  std::size_t line_no = 1;
  while (detail::next_line(bytes, pos, line)) {
    ++line_no;
    if (detail::split(line, tokens) == 0) continue;
    const std::string where = " (header line " + std::to_string(line_no) + ")";
    const std::string_view key = tokens[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") {
      if (!has_format) { error = "PLY header has no format line"; return false; }
      data_offset = pos;
      return true;
    }
    if (key == "format") {
      if (tokens.size() < 2) { error = "bad format" + where; return false; }
      if (tokens[1] == "ascii") format = Format::kAscii;
      else if (tokens[1] == "binary_little_endian") format = Format::kBinaryLE;
      else if (tokens[1] == "binary_big_endian") format = Format::kBinaryBE;
      else { error = "unknown PLY format '" + std::string(tokens[1]) + "'"; return false; }
      has_format = true;
    } else if (key == "element") {
      Element e;
      if (tokens.size() != 3 || !detail::parse_number(tokens[2], e.count)) {
        error = "bad element line" + where; return false;
      }
      e.name = std::string(tokens[1]);
      elements.push_back(std::move(e));
    } else if (key == "property") {
      if (elements.empty()) { error = "property before any element" + where; return false; }
      Property p;
      bool ok = false;
      if (tokens.size() == 5 && tokens[1] == "list") {
        p.is_list = true;
        ok = scalar_of(tokens[2], p.count_type) && scalar_of(tokens[3], p.type) &&
             p.count_type != Scalar::kF32 && p.count_type != Scalar::kF64;
        p.name = std::string(tokens[4]);
      } else if (tokens.size() == 3) {
        ok = scalar_of(tokens[1], p.type);
        p.name = std::string(tokens[2]);
      }
      if (!ok) { error = "bad property line" + where; return false; }
      elements.back().properties.push_back(std::move(p));
    } else {
      error = "unknown PLY header keyword '" + std::string(key) + "'" + where;
      return false;
    }
  }
  error = "PLY header has no end_header (truncated?)";
  return false;
}

// Sequential reader over the data section, ascii tokens or binary scalars, bounds-checked.
class Cursor {
 public:
  Cursor(std::span<const std::uint8_t> bytes, std::size_t pos, Format format)
      : bytes_(bytes), pos_(pos), format_(format) {}

  bool read(Scalar type, double& value) {
    if (format_ == Format::kAscii) {
      std::string_view token;
      return next_token(token) && detail::parse_number(token, value);
    }
    const std::size_t size = detail::scalar_size(type);
    if (size > bytes_.size() - pos_) return false;
    value = detail::load_scalar(type, bytes_.data() + pos_, format_ == Format::kBinaryBE);
    pos_ += size;
    return true;
  }

  bool skip(Scalar type, std::uint64_t n) {
    if (format_ == Format::kAscii) {
      std::string_view token;
      for (std::uint64_t i = 0; i < n; ++i) {
        if (!next_token(token)) return false;
      }
      return true;
    }
    const std::uint64_t size = detail::scalar_size(type);
    if (n > (bytes_.size() - pos_) / size) return false;
    pos_ += static_cast<std::size_t>(n * size);
    return true;
  }

  std::size_t remaining() const { return bytes_.size() - pos_; }

 private:
  bool next_token(std::string_view& token) {
    const char* data = reinterpret_cast<const char*>(bytes_.data());
    while (pos_ < bytes_.size() && (detail::is_space(data[pos_]) || data[pos_] == '\n')) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < bytes_.size() && !detail::is_space(data[pos_]) && data[pos_] != '\n') ++pos_;
    token = std::string_view(data + start, pos_ - start);
    return pos_ > start;
  }

  std::span<const std::uint8_t> bytes_;
  std::size_t pos_;
  Format format_;
};

bool read_list_length(Cursor& cursor, const Property& p, std::uint64_t& n) {
  double count = 0.0;
  if (!cursor.read(p.count_type, count) || !(count >= 0.0) || count > 1e9) return false;
  n = static_cast<std::uint64_t>(count);
  return true;
}

bool skip_instance(Cursor& cursor, const Element& e) {
  for (const Property& p : e.properties) {
    std::uint64_t n = 1;
    if (p.is_list && !read_list_length(cursor, p, n)) return false;
    if (!cursor.skip(p.type, n)) return false;
  }
  return true;
}

}  // namespace

bool parse_ply(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
               const ReadOptions& options, ReadStats* stats) {
  out.clear();
  Format format = Format::kAscii;
  std::vector<Element> elements;
  std::size_t data_offset = 0;
  if (!parse_header(bytes, format, elements, data_offset, error)) return false;

  std::size_t vertex_index = elements.size();
  for (std::size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].name == "vertex") { vertex_index = i; break; }
  }
  if (vertex_index == elements.size()) { error = "PLY has no vertex element"; return false; }
  const Element& vertex = elements[vertex_index];
  if (vertex.count > options.max_points) {
    error = "vertex count " + std::to_string(vertex.count) + " exceeds the limit of " +
            std::to_string(options.max_points);
    return false;
  }
  int role_property[kRoleCount] = {-1, -1, -1, -1, -1, -1, -1, -1};
  if (stats != nullptr) stats->skipped_fields.clear();
  for (std::size_t k = 0; k < vertex.properties.size(); ++k) {
    const Property& p = vertex.properties[k];
    const int role = p.is_list ? -1 : role_of(detail::to_lower(p.name));
    if (role >= 0 && role_property[role] < 0) role_property[role] = static_cast<int>(k);
    else if (stats != nullptr) stats->skipped_fields.push_back(p.name);
  }
  if (role_property[kX] < 0 || role_property[kY] < 0 || role_property[kZ] < 0) {
    error = "PLY vertex element lacks x, y and z"; return false;
  }

  Cursor cursor(bytes, data_offset, format);
  for (std::size_t i = 0; i < vertex_index; ++i) {
    // An instance without properties occupies no bytes: nothing to skip, however large the count
    // (2^64 - 1 of them used to spin for ever). Otherwise every property takes >= 1 byte (binary
    // scalar or ascii token), so a count above the remaining bytes is a lie: refuse it up front.
    if (elements[i].properties.empty()) continue;
    if (elements[i].count > cursor.remaining() / elements[i].properties.size()) {
      error = "truncated: PLY element '" + elements[i].name + "' has more instances than the data can hold";
      return false;
    }
    for (std::uint64_t j = 0; j < elements[i].count; ++j) {
      if (!skip_instance(cursor, elements[i])) {
        error = "truncated or malformed PLY data in element '" + elements[i].name + "'";
        return false;
      }
    }
  }

  const std::size_t n = static_cast<std::size_t>(vertex.count);
  // Each vertex needs at least one byte per property, bounding what a lying count can allocate.
  if (n > cursor.remaining() / std::max<std::size_t>(1, vertex.properties.size())) {
    error = "truncated: PLY header says " + std::to_string(n) + " vertices, data is too short";
    return false;
  }
  const bool has_intensity = role_property[kIntensity] >= 0;
  const bool has_time = role_property[kTime] >= 0;
  const bool has_normals = role_property[kNx] >= 0 && role_property[kNy] >= 0 && role_property[kNz] >= 0;
  out.points.resize(n);
  if (has_intensity) out.intensity.resize(n);
  if (has_time) out.time.resize(n);
  if (has_normals) out.normals.resize(n);
  std::vector<double> values(vertex.properties.size(), 0.0);
  auto value = [&](int role) { return static_cast<float>(values[static_cast<std::size_t>(role_property[role])]); };
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < vertex.properties.size(); ++k) {
      const Property& p = vertex.properties[k];
      bool ok = true;
      if (p.is_list) {
        std::uint64_t len = 0;
        ok = read_list_length(cursor, p, len) && cursor.skip(p.type, len);
      } else {
        ok = cursor.read(p.type, values[k]);
      }
      if (!ok) {
        error = "truncated or malformed PLY data at vertex " + std::to_string(i) + " of " +
                std::to_string(n);
        out.clear();
        return false;
      }
    }
    out.points[i] = Eigen::Vector3f(value(kX), value(kY), value(kZ));
    if (has_intensity) out.intensity[i] = value(kIntensity);
    if (has_time) out.time[i] = value(kTime);
    if (has_normals) out.normals[i] = Eigen::Vector3f(value(kNx), value(kNy), value(kNz));
  }
  out.width = static_cast<std::uint32_t>(n);
  out.height = 1;
  detail::finish_cloud(out, options, stats);
  return true;
}

bool read_ply(const std::string& path, PointCloud& out, std::string& error,
              const ReadOptions& options, ReadStats* stats) {
  std::vector<std::uint8_t> bytes;
  if (!read_file_bytes(path, bytes, error)) return false;
  if (!parse_ply(bytes, out, error, options, stats)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

bool encode_ply(const PointCloud& cloud, std::vector<std::uint8_t>& out, std::string& error) {
  out.clear();
  if (!cloud.consistent()) {
    error = "point cloud attributes do not have one entry per point";
    return false;
  }
  std::string h = "ply\nformat binary_little_endian 1.0\ncomment v2xloc cloud_io\nelement vertex " +
                  std::to_string(cloud.size()) + "\nproperty float x\nproperty float y\nproperty float z\n";
  if (cloud.has_intensity()) h += "property float intensity\n";
  if (cloud.has_time()) h += "property float t\n";
  if (cloud.has_normals()) h += "property float nx\nproperty float ny\nproperty float nz\n";
  h += "end_header\n";
  detail::append_text(out, h);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int a = 0; a < 3; ++a) detail::append(out, cloud.points[i][a]);
    if (cloud.has_intensity()) detail::append(out, cloud.intensity[i]);
    if (cloud.has_time()) detail::append(out, cloud.time[i]);
    if (cloud.has_normals()) {
      for (int a = 0; a < 3; ++a) detail::append(out, cloud.normals[i][a]);
    }
  }
  return true;
}

bool write_ply(const std::string& path, const PointCloud& cloud, std::string& error) {
  std::vector<std::uint8_t> bytes;
  if (!encode_ply(cloud, bytes, error)) {
    error = path + ": " + error;
    return false;
  }
  return write_file_bytes(path, bytes, error);
}

}  // namespace v2xloc::cloud_io
