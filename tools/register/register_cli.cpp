#include "tools/register/register_cli.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace v2xloc::tools {
namespace {

void append_number(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";  // JSON has no NaN/Inf
    return;
  }
  char buf[32];
  // 17 significant digits: the printed transform reads back to the same bits.
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  out += buf;
}

void append_ms(std::string& out, double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3f", v);
  out += buf;
}

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      q += '\\';
      q += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(c));
      q += buf;
    } else {
      q += c;
    }
  }
  return q + "\"";
}

void append_matrix(std::string& out, const Mat4d& m) {
  out += "[";
  for (int r = 0; r < 4; ++r) {
    out += r ? ",[" : "[";
    for (int c = 0; c < 4; ++c) {
      if (c) out += ",";
      append_number(out, m(r, c));
    }
    out += "]";
  }
  out += "]";
}

void append_registration(std::string& out, const RegistrationResult& r) {
  out += "\"status\":" + quoted(to_string(r.status)) + ",\"transform\":";
  append_matrix(out, r.transform);
  out += ",\"fitness\":";
  append_number(out, r.fitness);
  out += ",\"inlier_rmse\":";
  append_number(out, r.inlier_rmse);
  out += ",\"iterations\":" + std::to_string(r.iterations) + ",\"inliers\":" + std::to_string(r.inliers) +
         ",\"converged\":" + (r.converged ? "true" : "false");
}

}  // namespace

namespace {

// The command line, described once: parse_register_args and the usage text both come from it.
struct RegisterCommandLine {
  CLI::App app{"Registers SOURCE onto TARGET with the allocation-free pipeline (algo/register_clouds) and\n"
               "prints one JSON object. Exit 0: registered, 1: registration failed, 2: usage/IO error.",
               "v2xloc-register"};
  std::string mode = "global";
  float voxel = 0.0f;
  std::string init_path;
  std::uint64_t seed = 0;
  std::size_t feature_visits = 0;

  explicit RegisterCommandLine(RegisterOptions& o) {
    app.add_option("SOURCE", o.source_path, ".pcd (ascii/binary/binary_compressed), .ply or KITTI .bin")->required();
    app.add_option("TARGET", o.target_path, "the cloud SOURCE is registered onto (same formats)")->required();
    app.add_option("--voxel", voxel, "voxel size in metres (default 0.5); other radii scale with it")
        ->check(CLI::PositiveNumber);
    app.add_option("--init", init_path, "4x4 row-major initial guess p_target = T p_source (--mode icp)");
    app.add_option("--mode", mode, "global: FPFH + RANSAC + ICP (default); icp: ICP from --init")
        ->check(CLI::IsMember({"global", "icp"}));
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
  parsed.mode = cli.mode == "icp" ? RegistrationMode::kIcpOnly : RegistrationMode::kGlobal;
  options = parsed;
  return true;
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
                          const RegisterCloudsResult& result, const RegisterTimings& timings) {
  const RegisterStageStats& s = result.stats;
  std::string out = "{";
  append_registration(out, result.registration);
  out += ",\"mode\":";
  out += params.mode == RegistrationMode::kGlobal ? "\"global\"" : "\"icp\"";
  out += ",\"voxel\":";
  append_number(out, params.voxel_size);
  out += ",\"seed\":" + std::to_string(params.ransac.seed);
  out += ",\"feature_search_visits\":" + std::to_string(params.feature_search_visits);
  out += ",\"source\":" + quoted(options.source_path) + ",\"target\":" + quoted(options.target_path);
  out += ",\"coarse\":{";
  append_registration(out, result.coarse);
  out += "}";
  out += ",\"points\":{\"source_input\":" + std::to_string(s.source_input) +
         ",\"target_input\":" + std::to_string(s.target_input) +
         ",\"source_downsampled\":" + std::to_string(s.source_downsampled) +
         ",\"target_downsampled\":" + std::to_string(s.target_downsampled) +
         ",\"correspondences\":" + std::to_string(s.correspondences) +
         ",\"ransac_correspondence_inliers\":" + std::to_string(s.ransac_correspondence_inliers) +
         ",\"final_inliers\":" + std::to_string(result.registration.inliers) + "}";
  out += ",\"dropped\":{\"nonfinite\":" + std::to_string(result.registration.nonfinite_dropped) +
         ",\"source_truncated\":" + std::to_string(s.source_truncated) +
         ",\"target_truncated\":" + std::to_string(s.target_truncated) +
         ",\"downsample_overflow\":" + std::to_string(s.downsample_overflow) +
         ",\"correspondences_truncated\":" + std::to_string(s.correspondences_truncated) +
         ",\"search_cap_hits\":" + std::to_string(s.search_cap_hits) +
         ",\"feature_queries_cut\":" + std::to_string(s.feature_queries_cut) + "}";
  out += ",\"ransac_validations\":" + std::to_string(s.ransac_validations) +
         ",\"icp_iterations\":" + std::to_string(s.icp_iterations);
  static constexpr const char* kStageNames[] = {"downsample", "normals", "fpfh", "correspondences",
                                                "ransac", "icp"};
  static_assert(sizeof(kStageNames) / sizeof(kStageNames[0]) == static_cast<int>(RegisterStage::kCount));
  out += ",\"ms\":{\"read_source\":";
  append_ms(out, timings.read_source_ms);
  out += ",\"read_target\":";
  append_ms(out, timings.read_target_ms);
  for (int i = 0; i < static_cast<int>(RegisterStage::kCount); ++i) {
    out += ",\"" + std::string(kStageNames[i]) + "\":";
    append_ms(out, timings.stage_ms[i]);
  }
  out += ",\"registration\":";
  append_ms(out, timings.registration_ms);
  out += "}}\n";
  return out;
}

}  // namespace v2xloc::tools
