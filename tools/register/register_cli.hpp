// v2xloc-register's command line and JSON output, separate from main() so tests can call them.
#pragma once

#include "v2xloc/algo/registration/register_clouds.hpp"
#include "v2xloc/algo/registration/registration_verdict.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace v2xloc::tools {

struct RegisterOptions {
  std::string source_path;
  std::string target_path;
  std::optional<float> voxel;            // [m]; facade default when absent
  std::optional<std::string> init_path;  // 4x4 row-major text file (16 numbers)
  RegistrationMode mode = RegistrationMode::kGlobal;
  std::optional<std::uint64_t> seed;     // RANSAC PRNG seed
  std::optional<std::size_t> feature_visits;  // feature-query node-visit budget (0 = exact)
  std::optional<double> search_radius;   // [m] level search disc (mode search)
  std::optional<double> search_yaw_deg;  // [deg] level search heading window, full width (mode search)
};

// The parameters the options select (voxel, mode, seed, search window) over the defaults.
RegisterCloudsParams register_params(const RegisterOptions& options);

const char* register_usage();

// False with a message on bad usage (unknown flag, missing value, bad number, wrong arity).
bool parse_register_args(const std::vector<std::string>& args, RegisterOptions& options,
                         std::string& error);

// Reads 16 whitespace-separated numbers (row-major), '#' comments allowed; the last row must be
// 0 0 0 1 and the rotation block orthonormal within 1e-3.
bool read_matrix4(const std::string& path, Mat4d& matrix, std::string& error);

struct RegisterTimings {
  double read_source_ms = 0.0;
  double read_target_ms = 0.0;
  double stage_ms[static_cast<int>(RegisterStage::kCount)] = {};  // thread CPU time
  double registration_ms = 0.0;  // whole register_clouds call, thread CPU time
};

// One JSON object (single line + newline): status (the verdict's: "ok", "unreliable" or the
// failed registration's status), verdict (registration_verdict.hpp: reasons, evidence,
// thresholds), registration_status (the pipeline's own), transform (4 rows), fitness, inlier_rmse,
// iterations, inliers, converged, coarse (RANSAC) result, point counts per stage, overflow
// counters and per-stage milliseconds (rounded to 3 decimals). Written with nlohmann-json: other
// doubles round-trip to the same bits, NaN/Inf are null, and bytes of a file name that are not
// UTF-8 become U+FFFD.
std::string register_json(const RegisterOptions& options, const RegisterCloudsParams& params,
                          const RegisterCloudsResult& result, const RegisterTimings& timings,
                          const RegistrationVerdict& verdict, const VerdictParams& verdict_params);

}  // namespace v2xloc::tools
