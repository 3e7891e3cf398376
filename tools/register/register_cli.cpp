#include "tools/register/register_cli.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace v2xloc::tools {
namespace {

template <typename T>
bool parse_whole(const std::string& text, T& value) {
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && ptr == text.data() + text.size();
}

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

const char* register_usage() {
  return "usage: v2xloc-register SOURCE TARGET [--voxel M] [--init FILE_4x4] [--mode global|icp] "
         "[--seed N] [--feature-visits N]\n"
         "  SOURCE, TARGET  .pcd (ascii/binary/binary_compressed), .ply or KITTI .bin\n"
         "  --voxel M       voxel size in metres (default 0.5); other radii scale with it\n"
         "  --init FILE     4x4 row-major initial guess p_target = T p_source (--mode icp)\n"
         "  --mode          global: FPFH + RANSAC + ICP (default); icp: ICP from --init\n"
         "  --seed N        RANSAC random seed\n"
         "  --feature-visits N  node-visit budget per feature query (0 = exact, default;\n"
         "                      24: approximate, ~2x faster matching)\n"
         "Prints one JSON object. Exit 0: registered, 1: registration failed, 2: usage/IO error.\n";
}

bool parse_register_args(const std::vector<std::string>& args, RegisterOptions& options,
                         std::string& error) {
  std::vector<std::string> positional;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      if (i + 1 >= args.size()) {
        error = a + " needs a value";
        return false;
      }
      const std::string& value = args[++i];
      if (a == "--voxel") {
        float v = 0.0f;
        if (!parse_whole(value, v) || !(v > 0.0f) || !std::isfinite(v)) {
          error = "--voxel needs a positive number of metres, got '" + value + "'";
          return false;
        }
        options.voxel = v;
      } else if (a == "--init") {
        options.init_path = value;
      } else if (a == "--mode") {
        if (value == "global") options.mode = RegistrationMode::kGlobal;
        else if (value == "icp") options.mode = RegistrationMode::kIcpOnly;
        else {
          error = "--mode must be global or icp, got '" + value + "'";
          return false;
        }
      } else if (a == "--seed") {
        std::uint64_t s = 0;
        if (!parse_whole(value, s)) {
          error = "--seed needs a non-negative integer, got '" + value + "'";
          return false;
        }
        options.seed = s;
      } else if (a == "--feature-visits") {
        std::uint64_t v = 0;
        if (!parse_whole(value, v) || v > 1000000) {
          error = "--feature-visits needs an integer 0..1000000, got '" + value + "'";
          return false;
        }
        options.feature_visits = static_cast<std::size_t>(v);
      } else {
        error = "unknown option " + a;
        return false;
      }
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() != 2) {
    error = "expected SOURCE and TARGET, got " + std::to_string(positional.size()) + " file argument(s)";
    return false;
  }
  options.source_path = positional[0];
  options.target_path = positional[1];
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
