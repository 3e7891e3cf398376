// PCD reader. Header semantics follow PCL's pcd_io (v0.7): FIELDS/SIZE/TYPE/COUNT describe one
// point; binary data is array-of-structs with `stride` bytes per point; binary_compressed is
// <u32 compressed size><u32 raw size><LZF bytes> whose raw bytes are struct-of-arrays (all values
// of field 0, then field 1, ...). binary_shuffled_zlib (ours, pcd.hpp) is that layout with each
// field's block in byte planes, zlib-compressed, and a SCALE line applied to the stored integers.
#include "host_sim/cloud_io/cloud_io.hpp"
#include "host_sim/cloud_io/detail.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <type_traits>
#include <utility>

namespace v2xloc::cloud_io {
namespace {

using detail::Scalar;

enum class DataKind { kAscii, kBinary, kBinaryCompressed, kShuffledZlib };
enum Role : int { kX, kY, kZ, kIntensity, kTime, kNx, kNy, kNz, kRoleCount };

struct Field {
  std::string name;
  std::size_t size = 0;
  char type = 0;
  std::size_t count = 1;
  Scalar scalar = Scalar::kF32;
  std::size_t byte_offset = 0;   // within one point (binary) / per-field block start (compressed)
  std::size_t token_index = 0;   // first value's column in an ascii line
  double scale = 1.0;            // SCALE (binary_shuffled_zlib only): value = stored x scale
};

struct Header {
  std::vector<Field> fields;
  double time_offset = 0.0;  // ReadOptions::time_offset_s
  bool has_width = false;
  bool has_points = false;
  std::uint64_t width = 0;
  std::uint64_t height = 1;
  std::uint64_t points = 0;
  bool has_viewpoint = false;
  float viewpoint[7] = {0, 0, 0, 1, 0, 0, 0};
  DataKind kind = DataKind::kAscii;
  std::size_t data_offset = 0;
  std::size_t stride = 0;            // bytes per point
  std::size_t tokens_per_point = 0;  // values per ascii line
  int role_field[kRoleCount] = {-1, -1, -1, -1, -1, -1, -1, -1};
};

constexpr std::size_t kMaxFieldCount = 1 << 16;   // COUNT of one field
constexpr std::size_t kMaxStride = 1 << 20;       // bytes per point
constexpr std::uint64_t kMaxLzfExpansion = 88;    // a 3-byte back reference yields <= 264 bytes
constexpr std::uint64_t kMaxZlibExpansion = 1032;  // deflate's limit (zlib FAQ: 1032:1)

int role_of(const std::string& name) {
  if (name == "x") return kX;
  if (name == "y") return kY;
  if (name == "z") return kZ;
  if (name == "intensity") return kIntensity;
  if (name == "t" || name == "time" || name == "timestamp") return kTime;
  if (name == "normal_x") return kNx;
  if (name == "normal_y") return kNy;
  if (name == "normal_z") return kNz;
  return -1;
}

bool scalar_of(char type, std::size_t size, Scalar& s) {
  switch (type) {
    case 'F': if (size == 4) { s = Scalar::kF32; return true; }
              if (size == 8) { s = Scalar::kF64; return true; } return false;
    case 'I': if (size == 1) { s = Scalar::kI8; return true; }
              if (size == 2) { s = Scalar::kI16; return true; }
              if (size == 4) { s = Scalar::kI32; return true; }
              if (size == 8) { s = Scalar::kI64; return true; } return false;
    case 'U': if (size == 1) { s = Scalar::kU8; return true; }
              if (size == 2) { s = Scalar::kU16; return true; }
              if (size == 4) { s = Scalar::kU32; return true; }
              if (size == 8) { s = Scalar::kU64; return true; } return false;
    default: return false;
  }
}

template <typename T>
bool parse_list(const std::vector<std::string_view>& tokens, std::vector<T>& out) {
  out.resize(tokens.size() - 1);
  for (std::size_t i = 1; i < tokens.size(); ++i) {
    if (!detail::parse_number(tokens[i], out[i - 1])) return false;
  }
  return true;
}

// The per-field lists of a header (FIELDS, SIZE, TYPE, COUNT, SCALE), as read.
struct FieldLists {
  std::vector<std::string> names;
  std::vector<std::size_t> sizes;
  std::vector<std::size_t> counts;
  std::vector<char> types;
  std::vector<double> scales;
};

// VIEWPOINT: 7 finite numbers with a unit quaternion.
bool parse_viewpoint(const std::vector<std::string_view>& tokens, const std::string& where, Header& h,
                     std::string& error) {
  if (tokens.size() != 8) { error = "VIEWPOINT needs 7 values" + where; return false; }
  for (std::size_t i = 0; i < 7; ++i) {
    if (!detail::parse_number(tokens[i + 1], h.viewpoint[i])) {
      error = "bad VIEWPOINT" + where; return false;
    }
  }
  // The viewpoint becomes the sensor pose: inf/nan or a non-unit quaternion would silently
  // become a wrong transform downstream. PCL prints unit quaternions to >= 6 digits.
  const float* v = h.viewpoint;
  const float norm = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  if (!std::all_of(v, v + 7, [](float x) { return std::isfinite(x); }) || !(std::abs(norm - 1.0f) <= 1e-3f)) {
    error = "VIEWPOINT must be 7 finite numbers with a unit quaternion" + where; return false;
  }
  h.has_viewpoint = true;
  return true;
}

// A WIDTH, HEIGHT or POINTS line: one unsigned number.
bool parse_count_line(const std::vector<std::string_view>& tokens, const char* name, const std::string& where,
                      std::uint64_t& out, std::string& error) {
  if (tokens.size() != 2 || !detail::parse_number(tokens[1], out)) {
    error = std::string("bad ") + name + where; return false;
  }
  return true;
}

// DATA: the encoding of what follows the header.
bool parse_data_line(const std::vector<std::string_view>& tokens, const std::string& where, Header& h,
                     std::string& error) {
  const std::string kind = tokens.size() == 2 ? detail::to_lower(tokens[1]) : std::string();
  if (kind == "ascii") h.kind = DataKind::kAscii;
  else if (kind == "binary") h.kind = DataKind::kBinary;
  else if (kind == "binary_compressed") h.kind = DataKind::kBinaryCompressed;
  else if (kind == "binary_shuffled_zlib") h.kind = DataKind::kShuffledZlib;
  else { error = "unknown DATA type" + where; return false; }
  return true;
}

// One header line (its first token lower-cased in `key`). VERSION and unknown keywords are
// ignored, as PCL does.
bool parse_header_line(const std::string& key, const std::vector<std::string_view>& tokens, const std::string& where,
                       Header& h, FieldLists& lists, std::string& error) {
  if (key == "fields" || key == "columns") {
    lists.names.assign(tokens.begin() + 1, tokens.end());
  } else if (key == "size") {
    if (!parse_list(tokens, lists.sizes)) { error = "bad SIZE" + where; return false; }
  } else if (key == "count") {
    if (!parse_list(tokens, lists.counts)) { error = "bad COUNT" + where; return false; }
  } else if (key == "type") {
    lists.types.clear();
    for (std::size_t i = 1; i < tokens.size(); ++i) {
      if (tokens[i].size() != 1) { error = "bad TYPE" + where; return false; }
      lists.types.push_back(tokens[i][0]);
    }
  } else if (key == "scale") {
    if (!parse_list(tokens, lists.scales) ||
        !std::all_of(lists.scales.begin(), lists.scales.end(), [](double v) { return std::isfinite(v) && v > 0.0; })) {
      error = "SCALE needs finite positive numbers" + where; return false;
    }
  } else if (key == "width") {
    if (!parse_count_line(tokens, "WIDTH", where, h.width, error)) return false;
    h.has_width = true;
  } else if (key == "height") {
    if (!parse_count_line(tokens, "HEIGHT", where, h.height, error)) return false;
  } else if (key == "points") {
    if (!parse_count_line(tokens, "POINTS", where, h.points, error)) return false;
    h.has_points = true;
  } else if (key == "viewpoint") {
    if (!parse_viewpoint(tokens, where, h, error)) return false;
  } else if (key == "data") {
    if (!parse_data_line(tokens, where, h, error)) return false;
  }
  return true;
}

// The lists agree in length; each field's scalar type, count and place in a point record; the
// fields that carry x, y, z, intensity, time and normals.
bool build_fields(FieldLists& lists, Header& h, std::string& error) {
  const std::vector<std::string>& names = lists.names;
  if (names.empty()) { error = "missing FIELDS"; return false; }
  if (lists.sizes.size() != names.size() || lists.types.size() != names.size()) {
    error = "FIELDS, SIZE and TYPE disagree in length"; return false;
  }
  if (lists.counts.empty()) lists.counts.assign(names.size(), 1);
  if (lists.counts.size() != names.size()) { error = "FIELDS and COUNT disagree in length"; return false; }
  // PCL ignores unknown keywords: a SCALE in a standard file would be read unscaled elsewhere.
  if (!lists.scales.empty() && h.kind != DataKind::kShuffledZlib) {
    error = "SCALE is only defined for DATA binary_shuffled_zlib"; return false;
  }
  if (!lists.scales.empty() && lists.scales.size() != names.size()) {
    error = "FIELDS and SCALE disagree in length"; return false;
  }
  h.fields.resize(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    Field& f = h.fields[i];
    f.name = names[i];
    f.size = lists.sizes[i];
    f.type = lists.types[i];
    f.count = lists.counts[i];
    if (!lists.scales.empty()) f.scale = lists.scales[i];
    if (!scalar_of(f.type, f.size, f.scalar)) {
      error = "unsupported TYPE/SIZE '" + std::string(1, f.type) + std::to_string(f.size) +
              "' for field '" + f.name + "'";
      return false;
    }
    if (f.count == 0 || f.count > kMaxFieldCount) {
      error = "bad COUNT " + std::to_string(f.count) + " for field '" + f.name + "'"; return false;
    }
    f.byte_offset = h.stride;
    f.token_index = h.tokens_per_point;
    h.stride += f.size * f.count;
    h.tokens_per_point += f.count;
    if (h.stride > kMaxStride) { error = "point record larger than 1 MiB"; return false; }
    const int role = role_of(f.name);
    if (role >= 0 && f.count == 1 && h.role_field[role] < 0) h.role_field[role] = static_cast<int>(i);
  }
  if (h.role_field[kX] < 0 || h.role_field[kY] < 0 || h.role_field[kZ] < 0) {
    error = "FIELDS lack x, y and z"; return false;
  }
  return true;
}

// WIDTH and POINTS stand in for each other (POINTS = WIDTH x HEIGHT).
bool resolve_point_count(Header& h, std::string& error) {
  if (!h.has_width && !h.has_points) { error = "missing WIDTH and POINTS"; return false; }
  if (!h.has_width) { h.width = h.points; h.height = 1; }
  if (!h.has_points) {
    if (h.height != 0 && h.width > std::numeric_limits<std::uint64_t>::max() / h.height) {
      error = "WIDTH x HEIGHT overflows"; return false;
    }
    h.points = h.width * h.height;
  }
  return true;
}

bool parse_header(std::span<const std::uint8_t> bytes, Header& h, std::string& error) {
  FieldLists lists;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  std::string_view line;
  std::vector<std::string_view> tokens;
  bool has_data = false;
  while (!has_data && detail::next_line(bytes, pos, line)) {
    ++line_no;
    if (detail::split(line, tokens) == 0 || tokens[0].front() == '#') continue;
    const std::string key = detail::to_lower(tokens[0]);
    if (!parse_header_line(key, tokens, " (header line " + std::to_string(line_no) + ")", h, lists, error)) return false;
    has_data = key == "data";
  }
  if (!has_data) { error = "no DATA line: not a PCD file or truncated header"; return false; }
  h.data_offset = pos;
  return build_fields(lists, h, error) && resolve_point_count(h, error);
}

// Fills `out` one field at a time: column(field_index, dst, stride) writes the field's n values
// as float to dst[0], dst[stride], ... (stride 3 for x y z and normals, 1 for the rest).
template <typename Column>
void fill_cloud_by_column(const Header& h, std::size_t n, Column&& column, PointCloud& out) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
  out.clear();
  if (n == 0) return;  // no columns to write (and no pointer arithmetic on an empty vector's null data())
  out.points.resize(n);
  const int* rf = h.role_field;
  float* xyz = reinterpret_cast<float*>(out.points.data());
  for (int axis = 0; axis < 3; ++axis) column(rf[kX + axis], xyz + axis, 3);
  if (rf[kIntensity] >= 0) {
    out.intensity.resize(n);
    column(rf[kIntensity], out.intensity.data(), 1);
  }
  if (rf[kTime] >= 0) {
    out.time.resize(n);
    column(rf[kTime], out.time.data(), 1);
  }
  if (rf[kNx] >= 0 && rf[kNy] >= 0 && rf[kNz] >= 0) {
    out.normals.resize(n);
    float* normals = reinterpret_cast<float*>(out.normals.data());
    for (int axis = 0; axis < 3; ++axis) column(rf[kNx + axis], normals + axis, 3);
  }
}

// Fills `out` from a getter value(point, field_index) -> double.
template <typename Getter>
void fill_cloud(const Header& h, std::size_t n, Getter&& value, PointCloud& out) {
  fill_cloud_by_column(h, n, [&](int f, float* dst, std::size_t stride) {
    const double offset = f == h.role_field[kTime] ? h.time_offset : 0.0;
    for (std::size_t i = 0; i < n; ++i) dst[i * stride] = static_cast<float>(value(i, f) - offset);
  }, out);
}

bool read_ascii(std::span<const std::uint8_t> bytes, const Header& h, PointCloud& out,
                std::string& error) {
  // Parse only the columns we use into a dense table; other columns (rgb, ...) are not parsed.
  std::vector<int> used_columns;
  for (int f : h.role_field) {
    if (f >= 0) used_columns.push_back(f);
  }
  const std::size_t width = used_columns.size();
  std::vector<double> table;
  // Each value needs at least two characters, which bounds what a lying POINTS can make us reserve.
  const std::size_t remaining = bytes.size() - h.data_offset;
  table.reserve(std::min<std::size_t>(h.points, remaining / (2 * h.tokens_per_point) + 1) * width);
  std::size_t pos = h.data_offset;
  std::size_t n = 0;
  std::size_t line_no = 0;
  std::string_view line;
  std::vector<std::string_view> tokens;
  while (n < h.points && detail::next_line(bytes, pos, line)) {
    ++line_no;
    if (detail::split(line, tokens) == 0) continue;
    if (tokens.size() != h.tokens_per_point) {
      error = "data line " + std::to_string(line_no) + " has " + std::to_string(tokens.size()) +
              " values, header says " + std::to_string(h.tokens_per_point);
      return false;
    }
    for (int f : used_columns) {
      double v = 0.0;
      if (!detail::parse_number(tokens[h.fields[static_cast<std::size_t>(f)].token_index], v)) {
        error = "bad number in data line " + std::to_string(line_no);
        return false;
      }
      table.push_back(v);
    }
    ++n;
  }
  if (n < h.points) {
    error = "truncated: header says " + std::to_string(h.points) + " points, file has " +
            std::to_string(n);
    return false;
  }
  std::vector<std::size_t> column_of(h.fields.size(), 0);
  for (std::size_t c = 0; c < width; ++c) column_of[static_cast<std::size_t>(used_columns[c])] = c;
  fill_cloud(h, n, [&](std::size_t i, int f) { return table[i * width + column_of[static_cast<std::size_t>(f)]]; },
             out);
  return true;
}

bool checked_data_size(const Header& h, std::uint64_t& size, std::string& error) {
  if (h.points > std::numeric_limits<std::uint64_t>::max() / h.stride) {
    error = "POINTS x record size overflows"; return false;
  }
  size = h.points * h.stride;
  return true;
}

bool read_binary(std::span<const std::uint8_t> bytes, const Header& h, PointCloud& out,
                 std::string& error) {
  std::uint64_t need = 0;
  if (!checked_data_size(h, need, error)) return false;
  const std::size_t have = bytes.size() - h.data_offset;
  if (need > have) {
    error = "truncated: binary data has " + std::to_string(have) + " bytes, header needs " +
            std::to_string(need);
    return false;
  }
  const std::uint8_t* base = bytes.data() + h.data_offset;
  fill_cloud(h, static_cast<std::size_t>(h.points), [&](std::size_t i, int fi) {
    const Field& f = h.fields[static_cast<std::size_t>(fi)];
    return detail::load_scalar(f.scalar, base + i * h.stride + f.byte_offset);
  }, out);
  return true;
}

// The [compressed size][raw size] prefix both compressed encodings share, checked against the
// file (truncation), the header (POINTS x record size) and the codec's largest expansion.
struct CompressedBlock {
  const std::uint8_t* data = nullptr;
  std::uint32_t compressed = 0;
  std::uint32_t raw = 0;
};

bool read_block_sizes(std::span<const std::uint8_t> bytes, const Header& h, const char* encoding,
                      std::uint64_t max_expansion, CompressedBlock& block, std::string& error) {
  std::uint64_t need = 0;
  if (!checked_data_size(h, need, error)) return false;
  const std::size_t have = bytes.size() - h.data_offset;
  if (have < 8) { error = std::string("truncated: ") + encoding + " sizes missing"; return false; }
  const std::uint8_t* base = bytes.data() + h.data_offset;
  block.compressed = detail::load<std::uint32_t>(base);
  block.raw = detail::load<std::uint32_t>(base + 4);
  block.data = base + 8;
  if (block.compressed > have - 8) {
    error = "truncated: compressed block of " + std::to_string(block.compressed) + " bytes, file has " +
            std::to_string(have - 8);
    return false;
  }
  if (block.raw != need) {
    error = std::string(encoding) + " raw size " + std::to_string(block.raw) + " != POINTS x record size " +
            std::to_string(need);
    return false;
  }
  if (block.raw > std::uint64_t{block.compressed} * max_expansion + 64) {
    error = std::string(encoding) + " raw size impossible for its compressed size (lying header)";
    return false;
  }
  return true;
}

bool read_compressed(std::span<const std::uint8_t> bytes, const Header& h, PointCloud& out,
                     std::string& error) {
  CompressedBlock b;
  if (!read_block_sizes(bytes, h, "binary_compressed", kMaxLzfExpansion, b, error)) return false;
  const std::uint32_t raw = b.raw;
  std::vector<std::uint8_t> soa(raw);
  if (raw > 0 && lzf_decompress({b.data, b.compressed}, soa) != raw) {
    error = "corrupt LZF data in binary_compressed block"; return false;
  }
  // Struct-of-arrays: field f's values start at points * (bytes of the fields before f).
  fill_cloud(h, static_cast<std::size_t>(h.points), [&](std::size_t i, int fi) {
    const Field& f = h.fields[static_cast<std::size_t>(fi)];
    return detail::load_scalar(f.scalar, soa.data() + h.points * f.byte_offset + i * f.size * f.count);
  }, out);
  return true;
}

// One single-valued field of the byte-plane layout as float: byte k of value i at
// planes[k * n + i], the value scaled as the other readers' getters do (scale x stored, in double,
// then float). The byte gather is unrolled at compile time.
template <typename T>
void unshuffle_column(const std::uint8_t* planes, std::size_t n, double scale, double offset, float* dst,
                      std::size_t stride) {
  using Bits = std::conditional_t<sizeof(T) == 1, std::uint8_t,
               std::conditional_t<sizeof(T) == 2, std::uint16_t,
               std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
  const auto gather = [&]<std::size_t... K>(std::size_t i, std::index_sequence<K...>) {
    return static_cast<Bits>((Bits{0} | ... | static_cast<Bits>(static_cast<Bits>(planes[K * n + i]) << (8 * K))));
  };
  for (std::size_t i = 0; i < n; ++i) {
    const Bits bits = gather(i, std::make_index_sequence<sizeof(T)>{});
    dst[i * stride] = static_cast<float>(scale * static_cast<double>(std::bit_cast<T>(bits)) - offset);
  }
}

bool read_shuffled_zlib(std::span<const std::uint8_t> bytes, const Header& h, PointCloud& out,
                        std::string& error) {
  CompressedBlock b;
  if (!read_block_sizes(bytes, h, "binary_shuffled_zlib", kMaxZlibExpansion, b, error)) return false;
  const std::uint32_t raw = b.raw;
  // Not value-initialised: zlib writes every byte (checked), and zeroing 1 MB per scan showed.
  // Kept per thread: a fresh 1-2 MB block per cloud came back from the kernel page by page.
  thread_local std::unique_ptr<std::uint8_t[]> planes;
  thread_local std::size_t planes_capacity = 0;
  if (raw > planes_capacity) {
    planes.reset(new std::uint8_t[raw]);
    planes_capacity = raw;
  }
  if (raw > 0 && zlib_decompress({b.data, b.compressed}, {planes.get(), raw}) != raw) {
    error = "corrupt zlib data in binary_shuffled_zlib block"; return false;
  }
  // Field by field with the element type fixed per loop (a per-value type switch cost more than
  // the inflate).
  const std::size_t n = static_cast<std::size_t>(h.points);
  fill_cloud_by_column(h, n, [&](int fi, float* dst, std::size_t stride) {
    const Field& f = h.fields[static_cast<std::size_t>(fi)];  // a role field: COUNT 1 (parse_header)
    const std::uint8_t* block = planes.get() + h.points * f.byte_offset;
    const double offset = fi == h.role_field[kTime] ? h.time_offset : 0.0;
    switch (f.scalar) {
      case Scalar::kI8: return unshuffle_column<std::int8_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kU8: return unshuffle_column<std::uint8_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kI16: return unshuffle_column<std::int16_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kU16: return unshuffle_column<std::uint16_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kI32: return unshuffle_column<std::int32_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kU32: return unshuffle_column<std::uint32_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kI64: return unshuffle_column<std::int64_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kU64: return unshuffle_column<std::uint64_t>(block, n, f.scale, offset, dst, stride);
      case Scalar::kF32: return unshuffle_column<float>(block, n, f.scale, offset, dst, stride);
      case Scalar::kF64: return unshuffle_column<double>(block, n, f.scale, offset, dst, stride);
    }
  }, out);
  return true;
}

}  // namespace

bool parse_pcd(std::span<const std::uint8_t> bytes, PointCloud& out, std::string& error,
               const ReadOptions& options, ReadStats* stats) {
  out.clear();
  Header h;
  if (!parse_header(bytes, h, error)) return false;
  h.time_offset = options.time_offset_s;
  if (h.points > options.max_points) {
    error = "POINTS " + std::to_string(h.points) + " exceeds the limit of " +
            std::to_string(options.max_points);
    return false;
  }
  if (stats != nullptr) {
    stats->skipped_fields.clear();
    for (std::size_t i = 0; i < h.fields.size(); ++i) {
      bool used = false;
      for (int f : h.role_field) used = used || f == static_cast<int>(i);
      if (!used && h.fields[i].name != "_") stats->skipped_fields.push_back(h.fields[i].name);
    }
  }
  bool ok = false;
  switch (h.kind) {
    case DataKind::kAscii: ok = read_ascii(bytes, h, out, error); break;
    case DataKind::kBinary: ok = read_binary(bytes, h, out, error); break;
    case DataKind::kBinaryCompressed: ok = read_compressed(bytes, h, out, error); break;
    case DataKind::kShuffledZlib: ok = read_shuffled_zlib(bytes, h, out, error); break;
  }
  if (!ok) {
    out.clear();
    return false;
  }
  const bool organized = h.height > 1 && h.points % h.height == 0 && h.points / h.height == h.width;
  out.width = static_cast<std::uint32_t>(organized ? h.width : h.points);
  out.height = static_cast<std::uint32_t>(organized ? h.height : 1);
  out.has_viewpoint = h.has_viewpoint;
  out.sensor_origin = Eigen::Vector3f(h.viewpoint[0], h.viewpoint[1], h.viewpoint[2]);
  out.sensor_orientation = Eigen::Quaternionf(h.viewpoint[3], h.viewpoint[4], h.viewpoint[5], h.viewpoint[6]);
  detail::finish_cloud(out, options, stats);
  return true;
}

bool read_pcd(const std::string& path, PointCloud& out, std::string& error,
              const ReadOptions& options, ReadStats* stats) {
  std::vector<std::uint8_t> bytes;
  if (!read_file_bytes(path, bytes, error)) return false;
  if (!parse_pcd(bytes, out, error, options, stats)) {
    error = path + ": " + error;
    return false;
  }
  return true;
}

}  // namespace v2xloc::cloud_io
