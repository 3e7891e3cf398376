#include "tools/dataset/dair_calib.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace v2xloc::dataset {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string joined(const fs::path& dir, const std::string& relative) {
  const fs::path p(relative);
  return p.is_absolute() ? relative : (dir / p).string();
}

std::int64_t timestamp_of(const Json& entry) {
  if (!entry.contains("pointcloud_timestamp")) return 0;
  double v = 0.0;
  return dair_number(entry["pointcloud_timestamp"], v) ? static_cast<std::int64_t>(std::llround(v)) : 0;
}

// ROOT/<side>/data_info.json -> frames by id. An absent side stays empty.
bool load_side(const std::string& root, const char* side, const std::vector<const char*>& calib_keys,
               std::map<std::string, DairFrame>& frames, std::string& error) {
  frames.clear();
  const fs::path dir = fs::path(root) / side;
  const fs::path info_path = dir / "data_info.json";
  std::error_code ec;
  if (!fs::is_regular_file(info_path, ec)) return true;
  Json info;
  if (!read_dair_json(info_path.string(), info, error)) return false;
  if (!info.is_array()) {
    error = "'" + info_path.string() + "': expected a JSON array of frame entries";
    return false;
  }
  for (std::size_t i = 0; i < info.size(); ++i) {
    const Json& e = info[i];
    const std::string where = info_path.string() + " entry " + std::to_string(i);
    if (!e.is_object() || !e.contains("pointcloud_path") || !e["pointcloud_path"].is_string()) {
      error = where + ": needs a string pointcloud_path";
      return false;
    }
    DairFrame f;
    const std::string cloud = e["pointcloud_path"].get<std::string>();
    f.id = fs::path(cloud).stem().string();
    f.pointcloud_path = joined(dir, cloud);
    f.timestamp_us = timestamp_of(e);
    if (e.contains("batch_id") && e["batch_id"].is_string()) f.batch_id = e["batch_id"].get<std::string>();
    if (e.contains("intersection_loc") && e["intersection_loc"].is_string())
      f.intersection = e["intersection_loc"].get<std::string>();
    for (const char* key : calib_keys) {
      if (!e.contains(key) || !e[key].is_string()) {
        error = where + ": needs a string " + key;
        return false;
      }
      f.calib_paths.push_back(joined(dir, e[key].get<std::string>()));
    }
    frames[f.id] = std::move(f);
  }
  return true;
}

const DairFrame* find_frame(const std::map<std::string, DairFrame>& frames, const std::string& id,
                            const char* side, std::string& error) {
  const auto it = frames.find(id);
  if (it != frames.end()) return &it->second;
  error = std::string(side) + " frame '" + id + "' is not in " + side + "/data_info.json" +
          (frames.empty() ? " (absent or empty)" : "");
  return nullptr;
}

}  // namespace

bool dair_number(const Json& value, double& out) {
  if (value.is_number()) {
    out = value.get<double>();
  } else if (value.is_string()) {
    const std::string& s = value.get_ref<const std::string&>();
    if (s.empty()) return false;
    char* end = nullptr;
    out = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0') return false;
  } else {
    return false;
  }
  return std::isfinite(out);
}

bool read_dair_json(const std::string& path, nlohmann::json& out, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  out = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (out.is_discarded()) {
    error = "'" + path + "' is not valid JSON";
    return false;
  }
  return true;
}

bool read_dair_transform(const std::string& path, Mat4d& transform, std::string& error) {
  Json j;
  if (!read_dair_json(path, j, error)) return false;
  if (j.is_object() && j.contains("transform")) j = j["transform"];
  if (!j.is_object() || !j.contains("rotation") || !j.contains("translation")) {
    error = "'" + path + "': expected {\"rotation\": 3x3, \"translation\": 3x1}";
    return false;
  }
  const Json& r = j["rotation"];
  const Json& t = j["translation"];
  transform = Mat4d::Identity();
  bool ok = r.is_array() && r.size() == 3 && t.is_array() && t.size() == 3;
  for (std::size_t i = 0; ok && i < 3; ++i) {
    ok = r[i].is_array() && r[i].size() == 3;
    for (std::size_t k = 0; ok && k < 3; ++k) ok = dair_number(r[i][k], transform(int(i), int(k)));
    // translation: [[x],[y],[z]] in the release, [x,y,z] in some conversions.
    const Json& ti = t[i].is_array() && t[i].size() == 1 ? t[i][0] : t[i];
    if (ok) ok = dair_number(ti, transform(int(i), 3));
  }
  if (!ok) {
    error = "'" + path + "': rotation must be 3 rows of 3 numbers, translation 3 numbers";
    return false;
  }
  const Mat3d rot = transform.topLeftCorner<3, 3>();
  if ((rot.transpose() * rot - Mat3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 || rot.determinant() < 0.0) {
    error = "'" + path + "': rotation is not a rotation matrix";
    return false;
  }
  return true;
}

bool DairCalib::load(const std::string& root, std::string& error) {
  return load_side(root, "vehicle-side", {"calib_novatel_to_world_path", "calib_lidar_to_novatel_path"}, vehicle_,
                   error) &&
         load_side(root, "infrastructure-side", {"calib_virtuallidar_to_world_path"}, roadside_, error);
}

bool DairCalib::vehicle_calibs(const std::string& vehicle_id, Mat4d& world_T_novatel, Mat4d& novatel_T_lidar,
                               std::string& error) const {
  const DairFrame* f = find_frame(vehicle_, vehicle_id, "vehicle-side", error);
  return f != nullptr && read_dair_transform(f->calib_paths[0], world_T_novatel, error) &&
         read_dair_transform(f->calib_paths[1], novatel_T_lidar, error);
}

bool DairCalib::world_from_vehicle_lidar(const std::string& vehicle_id, Mat4d& world_T_lidar,
                                         std::string& error) const {
  Mat4d world_T_novatel, novatel_T_lidar;
  if (!vehicle_calibs(vehicle_id, world_T_novatel, novatel_T_lidar, error)) return false;
  world_T_lidar = world_T_novatel * novatel_T_lidar;
  return true;
}

bool DairCalib::world_from_roadside_lidar(const std::string& roadside_id, Mat4d& world_T_lidar,
                                          std::string& error, const DairOffset& offset) const {
  const DairFrame* f = find_frame(roadside_, roadside_id, "infrastructure-side", error);
  if (f == nullptr || !read_dair_transform(f->calib_paths[0], world_T_lidar, error)) return false;
  world_T_lidar(0, 3) += offset.delta_x;
  world_T_lidar(1, 3) += offset.delta_y;
  return true;
}

namespace {

// [R | t]^-1 with the general 3x3 inverse, as DAIR's tools invert (numpy matrix .I).
Mat4d inverse_as_dair(const Mat4d& m) {
  Mat4d out = Mat4d::Identity();
  const Mat3d r_inv = m.topLeftCorner<3, 3>().inverse();
  out.topLeftCorner<3, 3>() = r_inv;
  out.topRightCorner<3, 1>() = -r_inv * m.topRightCorner<3, 1>();
  return out;
}

}  // namespace

bool DairCalib::vehicle_from_roadside(const std::string& vehicle_id, const std::string& roadside_id,
                                      Mat4d& transform, std::string& error, const DairOffset& offset) const {
  Mat4d world_T_novatel, novatel_T_lidar, world_T_roadside;
  if (!vehicle_calibs(vehicle_id, world_T_novatel, novatel_T_lidar, error) ||
      !world_from_roadside_lidar(roadside_id, world_T_roadside, error, offset)) {
    return false;
  }
  // calib_i2v.py's order: roadside -> world -> novatel -> vehicle LiDAR.
  transform = inverse_as_dair(novatel_T_lidar) * (inverse_as_dair(world_T_novatel) * world_T_roadside);
  return true;
}

}  // namespace v2xloc::dataset
