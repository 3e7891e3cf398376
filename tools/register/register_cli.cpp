#include "tools/register/register_cli.hpp"
#include "tools/register/verdict_json.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>

namespace v2xloc::tools {
namespace {

using Json = nlohmann::ordered_json;  // keys in the order they are set, like v2xloc-info --json

// JSON has no NaN/Inf: those become null. Finite doubles are dumped shortest-round-trip, so the
// printed transform reads back to the same bits.
Json number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

// Milliseconds to the microsecond: more digits would be timer noise.
Json ms(double v) { return number(std::round(v * 1000.0) / 1000.0); }

Json matrix_rows(const Mat4d& m) {
  Json rows = Json::array();
  for (int r = 0; r < 4; ++r) {
    Json row = Json::array();
    for (int c = 0; c < 4; ++c) row.push_back(number(m(r, c)));
    rows.push_back(std::move(row));
  }
  return rows;
}

void add_registration(Json& out, const RegistrationResult& r) {
  out["status"] = to_string(r.status);
  out["transform"] = matrix_rows(r.transform);
  out["fitness"] = number(r.fitness);
  out["inlier_rmse"] = number(r.inlier_rmse);
  out["iterations"] = r.iterations;
  out["inliers"] = r.inliers;
  out["converged"] = r.converged;
}

Json point_counts(const RegisterCloudsResult& result) {
  const RegisterStageStats& s = result.stats;
  Json points;
  points["source_input"] = s.source_input;
  points["target_input"] = s.target_input;
  points["source_downsampled"] = s.source_downsampled;
  points["target_downsampled"] = s.target_downsampled;
  points["correspondences"] = s.correspondences;
  points["ransac_correspondence_inliers"] = s.ransac_correspondence_inliers;
  points["final_inliers"] = result.registration.inliers;
  points["voxel_used_m"] = s.voxel_used;  // coarser than asked when a cloud overflowed the capacity
  points["voxel_coarsenings"] = s.voxel_coarsenings;
  return points;
}

Json dropped_counts(const RegisterCloudsResult& result) {
  const RegisterStageStats& s = result.stats;
  Json dropped;
  dropped["nonfinite"] = result.registration.nonfinite_dropped;
  dropped["source_thinned"] = s.source_thinned;
  dropped["target_thinned"] = s.target_thinned;
  dropped["downsample_overflow"] = s.downsample_overflow;
  dropped["correspondences_truncated"] = s.correspondences_truncated;
  dropped["search_cap_hits"] = s.search_cap_hits;
  dropped["feature_queries_cut"] = s.feature_queries_cut;
  return dropped;
}

Json stage_ms(const RegisterTimings& timings) {
  static constexpr const char* kStageNames[] = {"downsample", "normals", "fpfh", "correspondences",
                                                "ransac", "icp", "search"};
  static_assert(std::size(kStageNames) == static_cast<std::size_t>(RegisterStage::kCount));
  Json out;
  out["read_source"] = ms(timings.read_source_ms);
  out["read_target"] = ms(timings.read_target_ms);
  for (std::size_t i = 0; i < std::size(kStageNames); ++i) out[kStageNames[i]] = ms(timings.stage_ms[i]);
  out["registration"] = ms(timings.registration_ms);
  return out;
}

}  // namespace

namespace {

// The command line, described once: parse_register_args and the usage text both come from it.
struct RegisterCommandLine {
  CLI::App app{"Registers SOURCE onto TARGET with the allocation-free pipeline (algo/register_clouds) and\n"
               "prints one JSON object with its verdict. Exit 0: verdict ok, 1: unreliable or failed, 2: usage/IO error.",
               "v2xloc-register"};
  std::string mode = "global";
  float voxel = 0.0f;
  std::string init_path;
  std::uint64_t seed = 0;
  std::size_t feature_visits = 0;
  double search_radius = 0.0;
  double search_yaw_deg = 0.0;

  explicit RegisterCommandLine(RegisterOptions& o) {
    app.add_option("SOURCE", o.source_path, ".pcd (ascii/binary/binary_compressed), .ply or KITTI .bin")->required();
    app.add_option("TARGET", o.target_path, "the cloud SOURCE is registered onto (same formats)")->required();
    app.add_option("--voxel", voxel, "voxel size in metres (default 0.5); other radii scale with it")
        ->check(CLI::PositiveNumber);
    app.add_option("--init", init_path, "4x4 row-major initial guess p_target = T p_source (--mode icp)");
    app.add_option("--mode", mode,
                   "global: FPFH + RANSAC + ICP (default); icp: ICP from --init; search: level search (x, y, yaw "
                   "lattice around --init, upright sensors) + ICP")
        ->check(CLI::IsMember({"global", "icp", "search"}));
    app.add_option("--search-radius", search_radius, "search: disc radius around --init [m] (default 80)")
        ->check(CLI::PositiveNumber);
    app.add_option("--search-yaw", search_yaw_deg, "search: heading window around --init, full width [deg] (default 360)")
        ->check(CLI::Range(0.0, 360.0));
    app.add_option("--seed", seed, "RANSAC random seed");
    app.add_option("--feature-visits", feature_visits,
                   "node-visit budget per feature query (0 = exact, default; 24: approximate, ~2x faster matching)")
        ->check(CLI::Range(std::size_t{0}, std::size_t{1000000}));
  }
};

}  // namespace

const char* register_usage() {
  static const std::string text = [] {
    RegisterOptions o;
    RegisterCommandLine cli(o);
    return cli.app.help();
  }();
  return text.c_str();
}

bool parse_register_args(const std::vector<std::string>& args, RegisterOptions& options,
                         std::string& error) {
  RegisterOptions parsed;
  RegisterCommandLine cli(parsed);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
  try {
    cli.app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    error = e.what();
    if (error.empty()) error = "bad usage";
    return false;
  }
  // Negative numbers for unsigned options: CLI11 would wrap some of them around.
  for (const char* name : {"--seed", "--feature-visits"}) {
    for (const std::string& v : cli.app.get_option(name)->results()) {
      if (!v.empty() && v.front() == '-') {
        error = std::string(name) + " needs a non-negative integer, got '" + v + "'";
        return false;
      }
    }
  }
  if (cli.app.count("--voxel")) parsed.voxel = cli.voxel;
  if (cli.app.count("--init")) parsed.init_path = cli.init_path;
  if (cli.app.count("--seed")) parsed.seed = cli.seed;
  if (cli.app.count("--feature-visits")) parsed.feature_visits = cli.feature_visits;
  if (cli.app.count("--search-radius")) parsed.search_radius = cli.search_radius;
  if (cli.app.count("--search-yaw")) parsed.search_yaw_deg = cli.search_yaw_deg;
  parsed.mode = cli.mode == "icp"      ? RegistrationMode::kIcpOnly
                : cli.mode == "search" ? RegistrationMode::kLevelSearch
                                       : RegistrationMode::kGlobal;
  options = parsed;
  return true;
}

RegisterCloudsParams register_params(const RegisterOptions& options) {
  RegisterCloudsParams params;
  params.mode = options.mode;
  if (options.voxel) params.voxel_size = *options.voxel;
  if (options.seed) params.ransac.seed = *options.seed;
  if (options.feature_visits) params.feature_search_visits = *options.feature_visits;
  if (options.search_radius) params.level.radius = *options.search_radius;
  if (options.search_yaw_deg) {
    params.level.yaw_span = *options.search_yaw_deg * 3.14159265358979323846 / 180.0;
    // One heading a degree over a window (at least 3), 5 deg steps over the whole circle.
    params.level.yaw_steps = *options.search_yaw_deg >= 360.0
                                 ? 72u
                                 : static_cast<std::uint32_t>(std::max(3.0, std::ceil(*options.search_yaw_deg) + 1.0));
  }
  return params;
}

bool read_matrix4(const std::string& path, Mat4d& matrix, std::string& error) {
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  std::string text, line;
  while (std::getline(in, line)) text += line.substr(0, line.find('#')) + "\n";
  std::istringstream values(text);
  for (int i = 0; i < 16; ++i) {
    double v = 0.0;
    if (!(values >> v) || !std::isfinite(v)) {
      error = "'" + path + "': expected 16 finite numbers (4x4 row-major)";
      return false;
    }
    matrix(i / 4, i % 4) = v;
  }
  std::string rest;
  if (values >> rest) {
    error = "'" + path + "': more than 16 numbers";
    return false;
  }
  if (matrix.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    error = "'" + path + "': last row must be 0 0 0 1";
    return false;
  }
  const Mat3d r = matrix.topLeftCorner<3, 3>();
  if ((r.transpose() * r - Mat3d::Identity()).cwiseAbs().maxCoeff() > 1e-3 || r.determinant() < 0.0) {
    error = "'" + path + "': rotation block is not a rotation";
    return false;
  }
  return true;
}

std::string register_json(const RegisterOptions& options, const RegisterCloudsParams& params,
                          const RegisterCloudsResult& result, const RegisterTimings& timings,
                          const RegistrationVerdict& verdict, const VerdictParams& verdict_params) {
  Json out;
  add_registration(out, result.registration);
  out["status"] = verdict_status(verdict);
  out["registration_status"] = to_string(result.registration.status);
  out["verdict"] = verdict_json(verdict, verdict_params);
  out["mode"] = params.mode == RegistrationMode::kGlobal ? "global"
                : params.mode == RegistrationMode::kIcpOnly ? "icp" : "search";
  out["voxel"] = number(params.voxel_size);
  out["seed"] = params.ransac.seed;
  out["feature_search_visits"] = params.feature_search_visits;
  out["source"] = options.source_path;
  out["target"] = options.target_path;
  Json& coarse = out["coarse"] = Json::object();
  add_registration(coarse, result.coarse);
  out["points"] = point_counts(result);
  out["dropped"] = dropped_counts(result);
  out["ransac_validations"] = result.stats.ransac_validations;
  out["icp_iterations"] = result.stats.icp_iterations;
  if (params.mode == RegistrationMode::kLevelSearch) {
    Json& search = out["search"] = Json::object();
    search["radius_m"] = params.level.radius;
    search["yaw_span_deg"] = params.level.yaw_span * 180.0 / 3.14159265358979323846;
    search["yaw_steps"] = params.level.yaw_steps;
    search["hypotheses"] = result.stats.search_hypotheses;
    search["refined"] = result.stats.search_refined;
    if (result.runner_up.ok()) add_registration(search["runner_up"] = Json::object(), result.runner_up);
  }
  out["ms"] = stage_ms(timings);
  // Invalid UTF-8 in a file name is replaced rather than thrown on: the result is still printed.
  return out.dump(-1, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace v2xloc::tools
