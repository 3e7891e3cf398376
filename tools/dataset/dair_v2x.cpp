#include "tools/dataset/dair_v2x.hpp"

#include "tools/dataset/dair_calib.hpp"
#include "tools/register/verdict_json.hpp"

#include "host_sim/cloud_io/cloud_io.hpp"
#include "tools/dataset/dataset_common.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace v2xloc::dataset {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string stem(const std::string& path) { return fs::path(path).stem().string(); }

std::string join(const std::string& root, const std::string& relative) {
  const fs::path p(relative);
  return p.is_absolute() ? relative : (fs::path(root) / p).string();
}

RegistrationWorkspace& workspace() {
  static RegistrationWorkspace ws;  // tens of MB: static, never on the stack
  return ws;
}

LevelSearchWorkspace& search_workspace() {
  static LevelSearchWorkspace ws;
  return ws;
}

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double unit_draw(std::uint64_t& state) { return static_cast<double>(splitmix64(state) >> 11) * 0x1.0p-53; }

// The references of one pair: lidar_i2v where present, else the per-frame calibrations.
bool pair_references(const DairPair& pair, const DairCalib& calib, DairPairResult& r, std::string& error) {
  if (is_file(pair.calib_path)) {
    if (!read_lidar_i2v(pair.calib_path, r.reference, error)) return false;
    r.reference_corrected = r.reference;
    r.reference_corrected(0, 3) += pair.delta_x;
    r.reference_corrected(1, 3) += pair.delta_y;
    r.reference_source = "lidar_i2v";
    return true;
  }
  std::string why;
  if (!calib.vehicle_from_roadside(pair.vehicle_id, pair.infrastructure_id, r.reference, why) ||
      !calib.vehicle_from_roadside(pair.vehicle_id, pair.infrastructure_id, r.reference_corrected, why,
                                   DairOffset{pair.delta_x, pair.delta_y})) {
    error = "no '" + pair.calib_path + "' and the per-frame calibrations do not give the transform: " + why;
    return false;
  }
  r.reference_source = "computed";
  return true;
}

// The search window of a GNSS-grade prior: the translation error plus the arc the yaw error
// sweeps at the sensors' distance, with margin; the yaw error twice over.
void prior_window(const DairOptions& o, const Mat4d& prior, RegisterCloudsParams& params) {
  const double yaw = o.prior_yaw_deg * M_PI / 180.0;
  const double reach = o.prior_translation_m + prior.topRightCorner<2, 1>().norm() * std::sin(yaw);
  params.level.radius = 1.5 * reach + 2.0;
  const double span_deg = std::max(4.0 * o.prior_yaw_deg, 4.0);
  params.level.yaw_span = span_deg * M_PI / 180.0;
  params.level.yaw_steps = static_cast<std::uint32_t>(std::ceil(span_deg)) + 1;  // ~1 deg apart
  params.level.step = 1.0;
}

}  // namespace

Mat4d dair_gnss_prior(const Mat4d& reference, double translation_m, double yaw_deg, std::uint64_t seed,
                      std::size_t index) {
  std::uint64_t state = seed ^ (0xD1B54A32D192ED03ull * (static_cast<std::uint64_t>(index) + 1));
  const double direction = 2.0 * M_PI * unit_draw(state);
  const double yaw = (unit_draw(state) < 0.5 ? -1.0 : 1.0) * yaw_deg * M_PI / 180.0;
  // delta: the vehicle's pose error (vehicle frame); the prior sees the roadside through it.
  Mat4d delta_inverse = Mat4d::Identity();
  const double c = std::cos(yaw), s = std::sin(yaw);
  Mat3d r;
  r << c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0;
  const Vec3d d(translation_m * std::cos(direction), translation_m * std::sin(direction), 0.0);
  delta_inverse.topLeftCorner<3, 3>() = r.transpose();
  delta_inverse.topRightCorner<3, 1>() = -r.transpose() * d;
  return delta_inverse * reference;
}

bool read_lidar_i2v(const std::string& path, Mat4d& transform, std::string& error) {
  return read_dair_transform(path, transform, error);
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
  if (!read_dair_json(info_path, info, error)) return false;
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
    // "" or null: no offset (DAIR's tools treat "" as none).
    const bool no_offset = !e.contains("system_error_offset") || e["system_error_offset"].is_null() ||
                           (e["system_error_offset"].is_string() && e["system_error_offset"].get<std::string>().empty());
    if (!no_offset) {
      const Json& o = e["system_error_offset"];
      if (!o.is_object() || !o.contains("delta_x") || !o.contains("delta_y") ||
          !dair_number(o["delta_x"], p.delta_x) || !dair_number(o["delta_y"], p.delta_y)) {
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
  DairCalib calib;
  if (!calib.load(options.root, error)) return false;
  if (options.limit && pairs.size() > options.limit) pairs.resize(options.limit);
  RegisterCloudsParams base;
  base.mode = options.mode;
  base.voxel_size = options.voxel;
  if (options.seed) base.ransac.seed = *options.seed;
  const bool use_prior = options.prior == DairPrior::kGnss && options.mode != RegistrationMode::kGlobal;
  cloud_io::PointCloud vehicle, infra;
  for (std::size_t index = 0; index < pairs.size(); ++index) {
    const DairPair& pair = pairs[index];
    DairPairResult r;
    r.pair = pair;
    std::string message;
    const auto t0 = std::chrono::steady_clock::now();
    if (!pair_references(pair, calib, r, message) || !cloud_io::read_cloud(pair.vehicle_path, vehicle, message) ||
        !cloud_io::read_cloud(pair.infrastructure_path, infra, message)) {
      r.status = "error";
      r.message = message;
      result.pairs.push_back(std::move(r));
      continue;
    }
    r.read_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    r.vehicle_points = vehicle.size();
    r.infrastructure_points = infra.size();
    RegisterCloudsParams params = base;
    // Normals face each LiDAR (PCD VIEWPOINT, the origin when absent).
    params.source_viewpoint = infra.has_viewpoint ? infra.sensor_origin : Vec3f::Zero();
    params.target_viewpoint = vehicle.has_viewpoint ? vehicle.sensor_origin : Vec3f::Zero();
    Mat4d initial = Mat4d::Identity();
    if (use_prior) {
      r.prior = dair_gnss_prior(r.reference_corrected, options.prior_translation_m, options.prior_yaw_deg,
                                options.prior_seed, index);
      r.prior_translation_error_m = translation_error_m(r.prior, r.reference_corrected);
      r.prior_rotation_error_deg = rotation_error_deg(r.prior, r.reference_corrected);
      initial = r.prior;
      if (options.mode == RegistrationMode::kLevelSearch) prior_window(options, r.prior, params);
    }
    const std::uint64_t c0 = thread_cpu_ns();
    const RegisterCloudsResult reg =
        register_clouds(infra.points, vehicle.points, params, initial, workspace(), search_workspace());
    r.ms = static_cast<double>(thread_cpu_ns() - c0) * 1e-6;
    r.verdict = judge_registration(reg.registration, reg.runner_up.ok() ? &reg.runner_up : nullptr, options.verdict);
    r.status = tools::verdict_status(r.verdict);
    r.estimate = reg.registration.transform;
    r.fitness = reg.registration.fitness;
    r.inlier_rmse = reg.registration.inlier_rmse;
    r.translation_error_m = translation_error_m(r.estimate, r.reference);
    r.rotation_error_deg = rotation_error_deg(r.estimate, r.reference);
    r.translation_error_corrected_m = translation_error_m(r.estimate, r.reference_corrected);
    r.rotation_error_corrected_deg = rotation_error_deg(r.estimate, r.reference_corrected);
    r.within_floor = r.translation_error_corrected_m <= options.success_translation_m &&
                     r.rotation_error_corrected_deg <= options.success_rotation_deg;
    result.pairs.push_back(std::move(r));
  }
  return true;
}

namespace {

const char* mode_name(RegistrationMode m) {
  return m == RegistrationMode::kGlobal ? "global" : m == RegistrationMode::kIcpOnly ? "icp" : "search";
}

}  // namespace

DairSummary dair_summary(const DairOptions& options, const DairRunResult& result) {
  (void)options;
  DairSummary s;
  s.pairs = result.pairs.size();
  s.skipped_missing = result.skipped_missing;
  for (const DairPairResult& r : result.pairs) {
    if (r.status == "error") {
      ++s.errors;
      continue;
    }
    const Verdict v = r.verdict.verdict;
    s.ok += v == Verdict::kOk ? 1 : 0;
    s.unreliable += v == Verdict::kUnreliable ? 1 : 0;
    s.failed += v == Verdict::kFailed ? 1 : 0;
    if (v != Verdict::kFailed) {
      s.within_floor += r.within_floor ? 1 : 0;
      s.ms.push_back(r.ms);
    }
    if (v == Verdict::kOk) {
      s.ok_within_floor += r.within_floor ? 1 : 0;
      s.ok_wrong += r.within_floor ? 0 : 1;
      s.translation_error.push_back(r.translation_error_corrected_m);
      s.rotation_error.push_back(r.rotation_error_corrected_deg);
    }
    if (v == Verdict::kUnreliable) s.unreliable_within_floor += r.within_floor ? 1 : 0;
  }
  return s;
}

nlohmann::ordered_json dair_json(const DairOptions& options, const DairRunResult& result) {
  using OJson = nlohmann::ordered_json;
  const auto matrix = [](const Mat4d& m) {
    OJson t = OJson::array();
    for (int i = 0; i < 4; ++i) t.push_back({m(i, 0), m(i, 1), m(i, 2), m(i, 3)});
    return t;
  };
  const bool use_prior = options.prior == DairPrior::kGnss && options.mode != RegistrationMode::kGlobal;
  OJson pairs = OJson::array();
  for (const DairPairResult& r : result.pairs) {
    OJson p;
    p["vehicle"] = r.pair.vehicle_id;
    p["infrastructure"] = r.pair.infrastructure_id;
    p["status"] = r.status;
    if (r.status == "error") {
      p["error"] = r.message;
      pairs.push_back(p);
      continue;
    }
    p["verdict"] = tools::verdict_json(r.verdict, options.verdict);
    p["reference"] = r.reference_source;
    p["within_floor"] = r.within_floor;
    p["translation_error_m"] = r.translation_error_m;
    p["rotation_error_deg"] = r.rotation_error_deg;
    p["translation_error_offset_corrected_m"] = r.translation_error_corrected_m;
    p["rotation_error_offset_corrected_deg"] = r.rotation_error_corrected_deg;
    p["system_error_offset"] = {{"delta_x", r.pair.delta_x}, {"delta_y", r.pair.delta_y}};
    p["fitness"] = r.fitness;
    p["inlier_rmse_m"] = r.inlier_rmse;
    p["points"] = {{"vehicle", r.vehicle_points}, {"infrastructure", r.infrastructure_points}};
    p["ms"] = r.ms;
    if (use_prior) {
      p["prior"] = {{"translation_error_m", r.prior_translation_error_m},
                    {"rotation_error_deg", r.prior_rotation_error_deg},
                    {"transform", matrix(r.prior)}};
    }
    p["transform"] = matrix(r.estimate);
    p["dataset_transform"] = matrix(r.reference_corrected);
    pairs.push_back(p);
  }
  const DairSummary s = dair_summary(options, result);
  OJson summary;
  summary["pairs"] = s.pairs;
  summary["registered"] = s.ok;
  summary["ok"] = s.ok;
  summary["unreliable"] = s.unreliable;
  summary["failed"] = s.failed;
  summary["errors"] = s.errors;
  summary["skipped_missing"] = s.skipped_missing;
  summary["mode"] = mode_name(options.mode);
  summary["voxel_m"] = options.voxel;
  if (use_prior) {
    summary["prior"] = {{"kind", "gnss"}, {"translation_m", options.prior_translation_m},
                        {"yaw_deg", options.prior_yaw_deg}, {"seed", options.prior_seed}};
  } else {
    summary["prior"] = {{"kind", "none"}};
  }
  summary["success_threshold"] = {{"translation_m", options.success_translation_m},
                                  {"rotation_deg", options.success_rotation_deg}};
  summary["within_floor"] = s.within_floor;
  summary["ok_within_floor"] = s.ok_within_floor;
  summary["ok_wrong"] = s.ok_wrong;
  summary["unreliable_within_floor"] = s.unreliable_within_floor;
  // Statistics only over what exists: none (null) rather than a mean over zero pairs.
  auto stats_json = [](const std::vector<double>& v) {
    if (v.empty()) return OJson(nullptr);
    const Stats st = stats_of(v);
    return OJson{{"mean", st.mean}, {"median", st.median}, {"max", st.max}};
  };
  summary["ok_translation_error_m"] = stats_json(s.translation_error);
  summary["ok_rotation_error_deg"] = stats_json(s.rotation_error);
  summary["ms"] = stats_json(s.ms);
  return OJson{{"root", options.root}, {"pairs", pairs}, {"summary", summary}};
}

std::string dair_table(const DairOptions& options, const DairRunResult& result) {
  std::string out;
  char line[400];
  std::snprintf(line, sizeof(line), "%-8s %-8s %-18s %-26s %9s %9s %8s %9s\n", "vehicle", "infra", "status",
                "reasons", "t_err[m]", "r_err[deg]", "fitness", "s");
  out += line;
  for (const DairPairResult& r : result.pairs) {
    if (r.status == "error") {
      std::snprintf(line, sizeof(line), "%-8s %-8s error: %s\n", r.pair.vehicle_id.c_str(),
                    r.pair.infrastructure_id.c_str(), r.message.c_str());
    } else {
      std::snprintf(line, sizeof(line), "%-8s %-8s %-18s %-26s %9.3f %9.3f %8.3f %9.2f%s\n", r.pair.vehicle_id.c_str(),
                    r.pair.infrastructure_id.c_str(), r.status.c_str(), tools::verdict_reasons_text(r.verdict).c_str(),
                    r.translation_error_corrected_m, r.rotation_error_corrected_deg, r.fitness, r.ms * 1e-3,
                    r.within_floor ? "  within floor" : "");
    }
    out += line;
  }
  const DairSummary s = dair_summary(options, result);
  const bool use_prior = options.prior == DairPrior::kGnss && options.mode != RegistrationMode::kGlobal;
  std::string prior = "no prior";
  if (use_prior) {
    std::snprintf(line, sizeof(line), "GNSS-grade prior (%.1f m, %.1f deg yaw, seed %llu)", options.prior_translation_m,
                  options.prior_yaw_deg, static_cast<unsigned long long>(options.prior_seed));
    prior = line;
  }
  std::snprintf(line, sizeof(line), "errors vs the dataset's transform (system_error_offset applied); mode %s, %s, voxel %.2f m\n",
                mode_name(options.mode), prior.c_str(), options.voxel);
  out += line;
  std::snprintf(line, sizeof(line), "%-12s %5s %12s\n", "verdict", "pairs", "within floor");
  out += line;
  std::snprintf(line, sizeof(line), "%-12s %5zu %12zu\n", "ok", s.ok, s.ok_within_floor);
  out += line;
  std::snprintf(line, sizeof(line), "%-12s %5zu %12zu\n", "unreliable", s.unreliable, s.unreliable_within_floor);
  out += line;
  std::snprintf(line, sizeof(line), "%-12s %5zu %12s\n", "failed", s.failed, "-");
  out += line;
  if (s.errors > 0) {
    std::snprintf(line, sizeof(line), "%-12s %5zu %12s\n", "error", s.errors, "-");
    out += line;
  }
  std::snprintf(line, sizeof(line),
                "%zu pairs (%zu skipped: clouds absent): %zu within %.2f m / %.1f deg of the dataset's transform, "
                "%zu ok (%zu of them wrong)\n",
                s.pairs, s.skipped_missing, s.within_floor, options.success_translation_m, options.success_rotation_deg,
                s.ok, s.ok_wrong);
  out += line;
  if (!s.translation_error.empty()) {
    const Stats t = stats_of(s.translation_error), rot = stats_of(s.rotation_error);
    std::snprintf(line, sizeof(line), "ok pairs: translation error mean %.3f / median %.3f m, rotation error mean %.3f / median %.3f deg\n",
                  t.mean, t.median, rot.mean, rot.median);
    out += line;
  }
  if (!s.ms.empty()) {
    std::snprintf(line, sizeof(line), "%.2f s/pair mean (thread CPU)\n", stats_of(s.ms).mean * 1e-3);
    out += line;
  }
  return out;
}

std::string dair_nothing_registered(const DairRunResult& result) {
  std::size_t unreliable = 0, failed = 0, errors = 0;
  std::string first_error;
  for (const DairPairResult& r : result.pairs) {
    if (r.status == "error") {
      if (errors++ == 0) first_error = r.message;
    } else if (r.verdict.verdict == Verdict::kUnreliable) {
      ++unreliable;
    } else if (r.verdict.verdict == Verdict::kFailed) {
      ++failed;
    }
  }
  std::string why = "no pair registered with an ok verdict (" + std::to_string(unreliable) + " unreliable, " +
                    std::to_string(failed) + " failed, " + std::to_string(errors) + " could not be read";
  if (!first_error.empty()) why += "; first: " + first_error;
  return why + ")";
}

}  // namespace v2xloc::dataset
