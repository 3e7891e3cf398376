#include "registration_test_support.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "v2xloc/algo/core/det_math.hpp"

namespace v2xloc::testing {
namespace {

constexpr double kRoadHalfWidth = 4.0;     // [m] carriageway (two lanes)
constexpr double kSidewalkWidth = 2.0;     // [m]
constexpr double kCurbHeight = 0.15;       // [m]
constexpr double kBlockStart = kRoadHalfWidth + kSidewalkWidth;
constexpr double kWorldHalfExtent = 60.0;  // [m]

// Piecewise-constant facade setback along a block face: segments of 5-14 m, setback 0-4 m,
// height 4-14 m. Segment i covers [start[i], start[i+1]).
struct FacadeProfile {
  std::vector<double> start;
  std::vector<double> setback;
  std::vector<double> height;
  std::size_t segment(double a) const {
    std::size_t i = 0;
    while (i + 1 < setback.size() && a >= start[i + 1]) ++i;
    return i;
  }
  double setback_at(double a) const { return setback[segment(a)]; }
};

struct Pole { double x, y, radius, height; };
struct Car { double x, y, yaw; };

struct UrbanWorld {
  // Quadrant q = (sx, sy) index 2*(sx<0) + (sy<0). Faces toward the x-street (profile along a=|x|)
  // and toward the y-street (profile along b=|y|).
  std::array<FacadeProfile, 4> along_x, along_y;
  std::vector<Pole> poles;
  std::vector<Car> cars;
};

FacadeProfile make_profile(Pcg32& rng) {
  FacadeProfile p;
  double a = kBlockStart;
  while (a < kWorldHalfExtent) {
    p.start.push_back(a);
    p.setback.push_back(rng.uniform(0.0, 4.0));
    p.height.push_back(rng.uniform(4.0, 14.0));
    a += rng.uniform(5.0, 14.0);
  }
  p.start.push_back(kWorldHalfExtent);
  return p;
}

UrbanWorld make_world(std::uint64_t seed) {
  Pcg32 rng(seed, 7);
  UrbanWorld w;
  for (int q = 0; q < 4; ++q) {
    w.along_x[q] = make_profile(rng);
    w.along_y[q] = make_profile(rng);
  }
  // Poles on the sidewalks of both streets (lamp posts, signs), irregular spacing.
  for (int street = 0; street < 2; ++street) {
    for (int side = -1; side <= 1; side += 2) {
      double s = -kWorldHalfExtent + rng.uniform(0.0, 6.0);
      while (s < kWorldHalfExtent) {
        if (std::abs(s) > kBlockStart + 1.0) {
          const double offset = side * (kRoadHalfWidth + rng.uniform(0.6, 1.6));
          Pole p{street == 0 ? s : offset, street == 0 ? offset : s, rng.uniform(0.08, 0.2),
                 rng.uniform(3.0, 8.0)};
          w.poles.push_back(p);
        }
        s += rng.uniform(6.0, 16.0);
      }
    }
  }
  // Parked cars along the curbs.
  for (int street = 0; street < 2; ++street) {
    for (int side = -1; side <= 1; side += 2) {
      double s = -kWorldHalfExtent + rng.uniform(0.0, 10.0);
      while (s < kWorldHalfExtent) {
        if (std::abs(s) > kBlockStart + 3.0) {
          const double offset = side * (kRoadHalfWidth - 1.2);
          const double yaw = (street == 0 ? 0.0 : det::kHalfPi) + rng.uniform(-0.1, 0.1);
          w.cars.push_back(Car{street == 0 ? s : offset, street == 0 ? offset : s, yaw});
        }
        s += rng.uniform(7.0, 25.0);
      }
    }
  }
  return w;
}

int quadrant(double x, double y) { return 2 * (x < 0 ? 1 : 0) + (y < 0 ? 1 : 0); }

// Inside a building block (behind both facade lines of its quadrant)?
bool inside_building(const UrbanWorld& w, double x, double y) {
  const int q = quadrant(x, y);
  const double a = std::abs(x), b = std::abs(y);
  if (a < kBlockStart || b < kBlockStart) return false;
  return b > kBlockStart + w.along_x[q].setback_at(a) && a > kBlockStart + w.along_y[q].setback_at(b);
}

double ground_height(double x, double y) {
  const bool on_road = std::abs(x) < kRoadHalfWidth || std::abs(y) < kRoadHalfWidth;
  return on_road ? 0.0 : kCurbHeight;
}

class Sampler {
 public:
  Sampler(const UrbanWorld& w, const UrbanSceneOptions& o, const Vec3d& sensor, Pcg32& rng,
          std::vector<Vec3d>& out)
      : world_(w), options_(o), sensor_(sensor), rng_(rng), out_(out) {}

  double gaussian() {  // Irwin-Hall(4), unit variance: no libm, same bits everywhere
    double s = 0.0;
    for (int i = 0; i < 4; ++i) s += rng_.uniform01();
    return (s - 2.0) * 1.7320508075688772;
  }
  bool in_range(const Vec3d& p) const {
    const double dx = p.x() - sensor_.x(), dy = p.y() - sensor_.y();
    return dx * dx + dy * dy <= options_.sensor_range * options_.sensor_range;
  }
  void emit(const Vec3d& p) {
    if (!in_range(p)) return;
    const double s = options_.noise_sigma;
    // One draw per statement: the evaluation order of function arguments is unspecified, and
    // GCC orders them differently on x86-64 and aarch64 (this broke cross-arch golden bits).
    const double nx = gaussian();
    const double ny = gaussian();
    const double nz = gaussian();
    out_.push_back(p + Vec3d(s * nx, s * ny, s * nz));
  }
  // Rectangle origin + u*[0,1] + v*[0,1]; keep(p) filters.
  template <class Keep>
  void rectangle(const Vec3d& origin, const Vec3d& u, const Vec3d& v, double density, Keep keep) {
    // Skip rectangles entirely out of range (bounding circle test).
    const Vec3d centre = origin + 0.5 * (u + v);
    const double half_diag = 0.5 * (u + v).norm() + 0.5 * (u - v).norm();
    const double dx = centre.x() - sensor_.x(), dy = centre.y() - sensor_.y();
    if (std::sqrt(dx * dx + dy * dy) > options_.sensor_range + half_diag) return;
    const double area = u.cross(v).norm();
    const auto n = static_cast<std::uint32_t>(area * density);
    for (std::uint32_t i = 0; i < n; ++i) {
      const double a = rng_.uniform01();
      const double b = rng_.uniform01();
      const Vec3d p = origin + a * u + b * v;
      if (keep(p)) emit(p);
    }
  }

  void ground() {
    const double r = options_.sensor_range;
    const auto n = static_cast<std::uint32_t>(4.0 * r * r * options_.ground_density);
    for (std::uint32_t i = 0; i < n; ++i) {
      const double x = sensor_.x() + rng_.uniform(-r, r);
      const double y = sensor_.y() + rng_.uniform(-r, r);
      if (inside_building(world_, x, y)) continue;
      emit(Vec3d(x, y, ground_height(x, y)));
    }
    // Curb faces along both streets.
    auto always = [](const Vec3d&) { return true; };
    for (int side = -1; side <= 1; side += 2) {
      for (int part = -1; part <= 1; part += 2) {
        const double from = part < 0 ? -kWorldHalfExtent : kRoadHalfWidth;
        const double len = kWorldHalfExtent - kRoadHalfWidth;
        rectangle(Vec3d(from, side * kRoadHalfWidth, 0.0), Vec3d(len, 0, 0),
                  Vec3d(0, 0, kCurbHeight), options_.structure_density, always);
        rectangle(Vec3d(side * kRoadHalfWidth, from, 0.0), Vec3d(0, len, 0),
                  Vec3d(0, 0, kCurbHeight), options_.structure_density, always);
      }
    }
  }

  void facades() {
    const double d = options_.structure_density;
    for (int q = 0; q < 4; ++q) {
      const double sx = (q & 2) ? -1.0 : 1.0, sy = (q & 1) ? -1.0 : 1.0;
      // Faces toward the x-street: y = sy (9 + setback(a)), a = |x| in the segment.
      for (int dir = 0; dir < 2; ++dir) {
        const FacadeProfile& prof = dir == 0 ? world_.along_x[q] : world_.along_y[q];
        const FacadeProfile& other = dir == 0 ? world_.along_y[q] : world_.along_x[q];
        for (std::size_t i = 0; i < prof.setback.size(); ++i) {
          const double a0 = prof.start[i], a1 = prof.start[i + 1];
          const double line = kBlockStart + prof.setback[i];
          const double h = prof.height[i];
          // Keep the facade only where it fronts a building (not in front of the other face).
          auto keep = [&](const Vec3d& p) {
            const double a = dir == 0 ? std::abs(p.x()) : std::abs(p.y());
            const double b = dir == 0 ? std::abs(p.y()) : std::abs(p.x());
            return a >= kBlockStart + other.setback_at(b) - 1e-9;
          };
          Vec3d origin, u;
          if (dir == 0) {
            origin = Vec3d(sx * a0, sy * line, 0.0);
            u = Vec3d(sx * (a1 - a0), 0.0, 0.0);
          } else {
            origin = Vec3d(sx * line, sy * a0, 0.0);
            u = Vec3d(0.0, sy * (a1 - a0), 0.0);
          }
          rectangle(origin, u, Vec3d(0, 0, h), d, keep);
          // Side wall to the next segment (the step between two setbacks).
          if (i + 1 < prof.setback.size()) {
            const double next = kBlockStart + prof.setback[i + 1];
            const double hh = h < prof.height[i + 1] ? h : prof.height[i + 1];
            const Vec3d o2 = dir == 0 ? Vec3d(sx * a1, sy * line, 0.0) : Vec3d(sx * line, sy * a1, 0.0);
            const Vec3d w2 = dir == 0 ? Vec3d(0.0, sy * (next - line), 0.0)
                                      : Vec3d(sx * (next - line), 0.0, 0.0);
            rectangle(o2, w2, Vec3d(0, 0, hh), d, keep);
          }
        }
      }
    }
  }

  void poles() {
    for (const Pole& p : world_.poles) {
      if (!in_range(Vec3d(p.x, p.y, 0.0))) continue;
      const auto n = static_cast<std::uint32_t>(2.0 * det::kPi * p.radius * p.height * options_.structure_density * 2.0);
      for (std::uint32_t i = 0; i < n; ++i) {
        const double ang = rng_.uniform(-det::kPi, det::kPi);
        const double z = rng_.uniform(0.0, p.height);
        emit(Vec3d(p.x + p.radius * det::cos(ang), p.y + p.radius * det::sin(ang), kCurbHeight + z));
      }
    }
  }

  void cars() {
    auto always = [](const Vec3d&) { return true; };
    for (const Car& c : world_.cars) {
      const Vec3d fwd(det::cos(c.yaw), det::sin(c.yaw), 0.0), left(-fwd.y(), fwd.x(), 0.0);
      const Vec3d centre(c.x, c.y, 0.3);
      const double l = 4.4, wd = 1.8, h = 1.2;
      const Vec3d corner = centre - 0.5 * l * fwd - 0.5 * wd * left;
      const Vec3d up(0, 0, h);
      const double d = options_.structure_density;
      rectangle(corner + up, l * fwd, wd * left, d, always);                // roof
      rectangle(corner, l * fwd, up, d, always);                            // right side
      rectangle(corner + wd * left, l * fwd, up, d, always);                // left side
      rectangle(corner, wd * left, up, d, always);                          // rear
      rectangle(corner + l * fwd, wd * left, up, d, always);                // front
    }
  }

 private:
  const UrbanWorld& world_;
  const UrbanSceneOptions& options_;
  Vec3d sensor_;
  Pcg32& rng_;
  std::vector<Vec3d>& out_;
};

std::vector<Vec3d> sample_world(const UrbanWorld& w, const UrbanSceneOptions& o, const Vec3d& sensor,
                                Pcg32& rng) {
  std::vector<Vec3d> pts;
  Sampler s(w, o, sensor, rng, pts);
  s.ground();
  s.facades();
  s.poles();
  s.cars();
  return pts;
}

}  // namespace

Mat4d rotation_zyx(double yaw, double pitch, double roll, const Vec3d& t) {
  const double cy = det::cos(yaw), sy = det::sin(yaw);
  const double cp = det::cos(pitch), sp = det::sin(pitch);
  const double cr = det::cos(roll), sr = det::sin(roll);
  Mat3d rz, ry, rx;
  rz << cy, -sy, 0, sy, cy, 0, 0, 0, 1;
  ry << cp, 0, sp, 0, 1, 0, -sp, 0, cp;
  rx << 1, 0, 0, 0, cr, -sr, 0, sr, cr;
  Mat4d m = Mat4d::Identity();
  m.topLeftCorner<3, 3>() = rz * ry * rx;
  m.topRightCorner<3, 1>() = t;
  return m;
}

Mat4d random_transform(Pcg32& rng, double max_yaw, double max_tilt, double max_translation) {
  const double yaw = rng.uniform(-max_yaw, max_yaw);
  const double pitch = rng.uniform(-max_tilt, max_tilt);
  const double roll = rng.uniform(-max_tilt, max_tilt);
  Vec3d t;
  do {
    const double tx = rng.uniform(-1, 1);  // one draw per statement (see Sampler::emit)
    const double ty = rng.uniform(-1, 1);
    const double tz = rng.uniform(-1, 1);
    t = Vec3d(tx, ty, tz);
  } while (t.squaredNorm() > 1.0);
  return rotation_zyx(yaw, pitch, roll, max_translation * t);
}

CloudPair make_urban_pair(std::uint64_t scene_seed, std::uint64_t sample_seed, const Mat4d& T,
                          const UrbanSceneOptions& options) {
  const UrbanWorld world = make_world(scene_seed);
  Pcg32 rng(sample_seed, 11);
  const Vec3d target_sensor(0.0, 0.0, 1.8);
  const Vec3d source_sensor(options.sensor_separation, 3.0, 1.8);
  const std::vector<Vec3d> target_world = sample_world(world, options, target_sensor, rng);
  const std::vector<Vec3d> source_world = sample_world(world, options, source_sensor, rng);
  CloudPair pair;
  pair.target_from_source = T;
  pair.target.reserve(target_world.size());
  for (const Vec3d& p : target_world) pair.target.push_back(p.cast<float>());
  const Mat3d rt = T.topLeftCorner<3, 3>().transpose();
  const Vec3d t = T.topRightCorner<3, 1>();
  std::size_t shared = 0;
  pair.source.reserve(source_world.size());
  for (const Vec3d& p : source_world) {
    pair.source.push_back((rt * (p - t)).cast<float>());
    const double dx = p.x() - target_sensor.x(), dy = p.y() - target_sensor.y();
    if (dx * dx + dy * dy <= options.sensor_range * options.sensor_range) ++shared;
  }
  pair.overlap = source_world.empty() ? 0.0 : double(shared) / double(source_world.size());
  return pair;
}

double translation_error(const Mat4d& estimate, const Mat4d& truth) {
  return (estimate.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm();
}

double rotation_error_deg(const Mat4d& estimate, const Mat4d& truth) {
  const Mat3d d = estimate.topLeftCorner<3, 3>().transpose() * truth.topLeftCorner<3, 3>();
  double c = (d.trace() - 1.0) / 2.0;
  c = c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c);
  return std::acos(c) * 180.0 / det::kPi;
}

std::vector<Vec3f> transform_cloud(const std::vector<Vec3f>& cloud, const Mat4d& T) {
  std::vector<Vec3f> out;
  out.reserve(cloud.size());
  const Mat3d r = T.topLeftCorner<3, 3>();
  const Vec3d t = T.topRightCorner<3, 1>();
  for (const Vec3f& p : cloud) out.push_back((r * p.cast<double>() + t).cast<float>());
  return out;
}

bool file_exists(const std::string& path) {
  std::ifstream f(path);
  return f.good();
}

bool read_ply_xyz(const std::string& path, std::vector<Vec3f>& points, std::string& error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  std::string line;
  std::getline(in, line);
  if (line.rfind("ply", 0) != 0) {
    error = "not a PLY file";
    return false;
  }
  std::string format;
  std::size_t vertices = 0;
  bool in_vertex = false;
  struct Property { std::string name; int size; std::string type; };
  std::vector<Property> props;
  auto type_size = [](const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "double" || t == "float64") return 8;
    return 4;
  };
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "format") {
      ss >> format;
    } else if (key == "element") {
      std::string name;
      ss >> name;
      in_vertex = name == "vertex";
      if (in_vertex) ss >> vertices;
    } else if (key == "property" && in_vertex) {
      std::string type, name;
      ss >> type >> name;
      if (type == "list") {
        error = "list property in vertex element";
        return false;
      }
      props.push_back({name, type_size(type), type});
    } else if (key == "end_header") {
      break;
    }
  }
  int ix = -1, iy = -1, iz = -1;
  std::size_t stride = 0;
  std::vector<std::size_t> offset;
  for (std::size_t i = 0; i < props.size(); ++i) {
    offset.push_back(stride);
    stride += static_cast<std::size_t>(props[i].size);
    if (props[i].name == "x") ix = static_cast<int>(i);
    if (props[i].name == "y") iy = static_cast<int>(i);
    if (props[i].name == "z") iz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) {
    error = "no x/y/z";
    return false;
  }
  points.clear();
  points.reserve(vertices);
  if (format == "ascii") {
    for (std::size_t v = 0; v < vertices && std::getline(in, line); ++v) {
      std::istringstream ss(line);
      std::vector<double> vals(props.size());
      for (double& x : vals) ss >> x;
      points.emplace_back(float(vals[ix]), float(vals[iy]), float(vals[iz]));
    }
  } else if (format == "binary_little_endian") {
    std::vector<char> rec(stride);
    auto read_value = [&](int i) {
      const char* p = rec.data() + offset[i];
      if (props[i].size == 8) {
        double d;
        std::memcpy(&d, p, 8);
        return float(d);
      }
      float f;
      std::memcpy(&f, p, 4);
      return f;
    };
    for (std::size_t v = 0; v < vertices; ++v) {
      if (!in.read(rec.data(), static_cast<std::streamsize>(stride))) {
        error = "truncated PLY body";
        return false;
      }
      points.emplace_back(read_value(ix), read_value(iy), read_value(iz));
    }
  } else {
    error = "unsupported PLY format " + format;
    return false;
  }
  return points.size() == vertices;
}

bool read_pcd_ascii_xyz(const std::string& path, std::vector<Vec3f>& points, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  std::string line;
  std::vector<std::string> fields;
  std::size_t count = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "FIELDS") {
      std::string f;
      while (ss >> f) fields.push_back(f);
    } else if (key == "POINTS") {
      ss >> count;
    } else if (key == "DATA") {
      std::string kind;
      ss >> kind;
      if (kind != "ascii") {
        error = "only ascii PCD supported here";
        return false;
      }
      break;
    }
  }
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (fields[i] == "x") ix = static_cast<int>(i);
    if (fields[i] == "y") iy = static_cast<int>(i);
    if (fields[i] == "z") iz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) {
    error = "no x/y/z";
    return false;
  }
  points.clear();
  while (points.size() < count && std::getline(in, line)) {
    std::istringstream ss(line);
    std::vector<double> vals(fields.size());
    for (double& x : vals) ss >> x;
    points.emplace_back(float(vals[ix]), float(vals[iy]), float(vals[iz]));
  }
  return points.size() == count;
}

bool read_matrix4(const std::string& path, Mat4d& m, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  std::string line;
  int row = 0;
  while (row < 4 && std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    for (int c = 0; c < 4; ++c) {
      if (!(ss >> m(row, c))) {
        error = "bad matrix row";
        return false;
      }
    }
    ++row;
  }
  if (row != 4) error = "fewer than 4 rows";
  return row == 4;
}

}  // namespace v2xloc::testing
