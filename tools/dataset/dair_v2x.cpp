#include "tools/dataset/dair_v2x.hpp"

#include "host_sim/cloud_io/cloud_io.hpp"
#include "tools/dataset/dataset_common.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

namespace v2xloc::dataset {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

bool parse_json_file(const std::string& path, Json& out, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  out = Json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (out.is_discarded()) {
    error = "'" + path + "' is not valid JSON";
    return false;
  }
  return true;
}

bool number_at(const Json& j, double& v) {
  if (!j.is_number()) return false;
  v = j.get<double>();
  return std::isfinite(v);
}

std::string stem(const std::string& path) { return fs::path(path).stem().string(); }

std::string join(const std::string& root, const std::string& relative) {
  const fs::path p(relative);
  return p.is_absolute() ? relative : (fs::path(root) / p).string();
}

RegistrationWorkspace& workspace() {
  static RegistrationWorkspace ws;  // tens of MB: static, never on the stack
  return ws;
}

}  // namespace

bool read_lidar_i2v(const std::string& path, Mat4d& transform, std::string& error) {
  Json j;
  if (!parse_json_file(path, j, error)) return false;
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
    for (std::size_t k = 0; ok && k < 3; ++k) ok = number_at(r[i][k], transform(int(i), int(k)));
    // translation: [[x],[y],[z]] in the release, [x,y,z] in some conversions.
    const Json& ti = t[i].is_array() && t[i].size() == 1 ? t[i][0] : t[i];
    if (ok) ok = number_at(ti, transform(int(i), 3));
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

bool read_dair_pairs(const std::string& root, std::vector<DairPair>& pairs, std::size_t& missing,
                     std::string& error) {
  pairs.clear();
  missing = 0;
  if (!is_directory(root)) {
    error = "'" + root + "' is not a directory (expected a DAIR-V2X-C cooperative root)";
    return false;
  }
  const std::string info_path = root + "/cooperative/data_info.json";
  if (!is_file(info_path)) {
    error = "'" + root + "' has no cooperative/data_info.json (DAIR-V2X-C layout: cooperative/, "
            "vehicle-side/, infrastructure-side/)";
    return false;
  }
  Json info;
  if (!parse_json_file(info_path, info, error)) return false;
  if (!info.is_array()) {
    error = "'" + info_path + "': expected a JSON array of pair entries";
    return false;
  }
  for (std::size_t i = 0; i < info.size(); ++i) {
    const Json& e = info[i];
    const std::string where = info_path + " entry " + std::to_string(i);
    if (!e.is_object() || !e.contains("vehicle_pointcloud_path") ||
        !e.contains("infrastructure_pointcloud_path") || !e["vehicle_pointcloud_path"].is_string() ||
        !e["infrastructure_pointcloud_path"].is_string()) {
      error = where + ": needs string fields vehicle_pointcloud_path and infrastructure_pointcloud_path";
      return false;
    }
    DairPair p;
    const std::string vehicle_rel = e["vehicle_pointcloud_path"].get<std::string>();
    const std::string infra_rel = e["infrastructure_pointcloud_path"].get<std::string>();
    p.vehicle_id = stem(vehicle_rel);
    p.infrastructure_id = stem(infra_rel);
    p.vehicle_path = join(root, vehicle_rel);
    p.infrastructure_path = join(root, infra_rel);
    if (e.contains("calib_lidar_i2v_path") && e["calib_lidar_i2v_path"].is_string()) {
      p.calib_path = join(root, e["calib_lidar_i2v_path"].get<std::string>());
    } else {
      p.calib_path = root + "/cooperative/calib/lidar_i2v/" + p.vehicle_id + ".json";
    }
    if (e.contains("system_error_offset") && !e["system_error_offset"].is_null()) {
      const Json& o = e["system_error_offset"];
      if (!o.is_object() || !o.contains("delta_x") || !o.contains("delta_y") ||
          !number_at(o["delta_x"], p.delta_x) || !number_at(o["delta_y"], p.delta_y)) {
        error = where + ": system_error_offset needs numbers delta_x and delta_y";
        return false;
      }
      p.has_offset = true;
    }
    if (!is_file(p.vehicle_path) || !is_file(p.infrastructure_path)) {
      ++missing;
      continue;
    }
    pairs.push_back(std::move(p));
  }
  if (pairs.empty()) {
    error = "'" + root + "': none of the " + std::to_string(info.size()) +
            " pairs in cooperative/data_info.json has both point clouds present";
    return false;
  }
  return true;
}

bool run_dair(const DairOptions& options, DairRunResult& result, std::string& error) {
  result = DairRunResult{};
  std::vector<DairPair> pairs;
  if (!read_dair_pairs(options.root, pairs, result.skipped_missing, error)) return false;
  if (options.limit && pairs.size() > options.limit) pairs.resize(options.limit);
  RegisterCloudsParams params;
  params.voxel_size = options.voxel;
  if (options.seed) params.ransac.seed = *options.seed;
  cloud_io::PointCloud vehicle, infra;
  for (const DairPair& pair : pairs) {
    DairPairResult r;
    r.pair = pair;
    std::string message;
    const auto t0 = std::chrono::steady_clock::now();
    if (!read_lidar_i2v(pair.calib_path, r.reference, message) ||
        !cloud_io::read_cloud(pair.vehicle_path, vehicle, message) ||
        !cloud_io::read_cloud(pair.infrastructure_path, infra, message)) {
      r.status = "error";
      r.message = message;
      result.pairs.push_back(std::move(r));
      continue;
    }
    r.read_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    r.vehicle_points = vehicle.size();
    r.infrastructure_points = infra.size();
    // Normals face each LiDAR (PCD VIEWPOINT, the origin when absent).
    params.source_viewpoint = infra.has_viewpoint ? infra.sensor_origin : Vec3f::Zero();
    params.target_viewpoint = vehicle.has_viewpoint ? vehicle.sensor_origin : Vec3f::Zero();
    const std::uint64_t c0 = thread_cpu_ns();
    const RegisterCloudsResult reg =
        register_clouds(infra.points, vehicle.points, params, Mat4d::Identity(), workspace());
    r.ms = static_cast<double>(thread_cpu_ns() - c0) * 1e-6;
    r.status = reg.registration.ok() ? "ok" : to_string(reg.registration.status);
    r.estimate = reg.registration.transform;
    r.fitness = reg.registration.fitness;
    r.inlier_rmse = reg.registration.inlier_rmse;
    r.translation_error_m = translation_error_m(r.estimate, r.reference);
    r.rotation_error_deg = rotation_error_deg(r.estimate, r.reference);
    Mat4d corrected = r.reference;
    corrected(0, 3) += pair.delta_x;
    corrected(1, 3) += pair.delta_y;
    r.translation_error_corrected_m = translation_error_m(r.estimate, corrected);
    result.pairs.push_back(std::move(r));
  }
  return true;
}

nlohmann::ordered_json dair_json(const DairOptions& options, const DairRunResult& result) {
  using OJson = nlohmann::ordered_json;
  OJson pairs = OJson::array();
  std::vector<double> te, re, tc, ms;
  std::size_t ok = 0, errors = 0, success = 0, success_corrected = 0;
  for (const DairPairResult& r : result.pairs) {
    OJson p;
    p["vehicle"] = r.pair.vehicle_id;
    p["infrastructure"] = r.pair.infrastructure_id;
    p["status"] = r.status;
    if (r.status == "error") {
      p["error"] = r.message;
      ++errors;
      pairs.push_back(p);
      continue;
    }
    p["translation_error_m"] = r.translation_error_m;
    p["rotation_error_deg"] = r.rotation_error_deg;
    p["translation_error_offset_corrected_m"] = r.translation_error_corrected_m;
    p["system_error_offset"] = {{"delta_x", r.pair.delta_x}, {"delta_y", r.pair.delta_y}};
    p["fitness"] = r.fitness;
    p["inlier_rmse_m"] = r.inlier_rmse;
    p["points"] = {{"vehicle", r.vehicle_points}, {"infrastructure", r.infrastructure_points}};
    p["ms"] = r.ms;
    OJson t = OJson::array();
    for (int i = 0; i < 4; ++i) t.push_back({r.estimate(i, 0), r.estimate(i, 1), r.estimate(i, 2), r.estimate(i, 3)});
    p["transform"] = t;
    pairs.push_back(p);
    ms.push_back(r.ms);
    if (r.status != "ok") continue;
    ++ok;
    te.push_back(r.translation_error_m);
    re.push_back(r.rotation_error_deg);
    tc.push_back(r.translation_error_corrected_m);
    const bool rot_ok = r.rotation_error_deg <= options.success_rotation_deg;
    success += (rot_ok && r.translation_error_m <= options.success_translation_m) ? 1 : 0;
    success_corrected += (rot_ok && r.translation_error_corrected_m <= options.success_translation_m) ? 1 : 0;
  }
  auto stats_json = [](const std::vector<double>& v) {
    const Stats s = stats_of(v);
    return OJson{{"mean", s.mean}, {"median", s.median}, {"max", s.max}};
  };
  OJson summary;
  summary["pairs"] = result.pairs.size();
  summary["registered"] = ok;
  summary["failed"] = result.pairs.size() - ok - errors;
  summary["errors"] = errors;
  summary["skipped_missing"] = result.skipped_missing;
  summary["voxel_m"] = options.voxel;
  summary["success_threshold"] = {{"translation_m", options.success_translation_m},
                                  {"rotation_deg", options.success_rotation_deg}};
  summary["success"] = success;
  summary["success_offset_corrected"] = success_corrected;
  summary["translation_error_m"] = stats_json(te);
  summary["rotation_error_deg"] = stats_json(re);
  summary["translation_error_offset_corrected_m"] = stats_json(tc);
  summary["ms"] = stats_json(ms);
  return OJson{{"root", options.root}, {"pairs", pairs}, {"summary", summary}};
}

std::string dair_table(const DairOptions& options, const DairRunResult& result) {
  const nlohmann::ordered_json j = dair_json(options, result);
  std::string out;
  char line[320];
  std::snprintf(line, sizeof(line), "%-8s %-8s %-20s %9s %9s %11s %9s\n", "vehicle", "infra", "status",
                "t_err[m]", "r_err[deg]", "t_err_corr", "ms");
  out += line;
  for (const DairPairResult& r : result.pairs) {
    if (r.status == "error") {
      std::snprintf(line, sizeof(line), "%-8s %-8s error: %s\n", r.pair.vehicle_id.c_str(),
                    r.pair.infrastructure_id.c_str(), r.message.c_str());
    } else {
      std::snprintf(line, sizeof(line), "%-8s %-8s %-20s %9.3f %9.3f %11.3f %9.1f\n", r.pair.vehicle_id.c_str(),
                    r.pair.infrastructure_id.c_str(), r.status.c_str(), r.translation_error_m,
                    r.rotation_error_deg, r.translation_error_corrected_m, r.ms);
    }
    out += line;
  }
  const auto& s = j["summary"];
  std::snprintf(line, sizeof(line),
                "%zu pairs (%zu skipped: clouds absent): %zu registered, %zu within %.2f m / %.1f deg "
                "(%zu with the offset applied)\n",
                s["pairs"].get<std::size_t>(), s["skipped_missing"].get<std::size_t>(),
                s["registered"].get<std::size_t>(), s["success"].get<std::size_t>(),
                options.success_translation_m, options.success_rotation_deg,
                s["success_offset_corrected"].get<std::size_t>());
  out += line;
  std::snprintf(line, sizeof(line),
                "registered pairs: translation error mean %.3f / median %.3f m (offset corrected %.3f / %.3f), "
                "rotation error mean %.3f / median %.3f deg, %.1f ms/pair mean\n",
                s["translation_error_m"]["mean"].get<double>(), s["translation_error_m"]["median"].get<double>(),
                s["translation_error_offset_corrected_m"]["mean"].get<double>(),
                s["translation_error_offset_corrected_m"]["median"].get<double>(),
                s["rotation_error_deg"]["mean"].get<double>(), s["rotation_error_deg"]["median"].get<double>(),
                s["ms"]["mean"].get<double>());
  out += line;
  return out;
}

}  // namespace v2xloc::dataset
