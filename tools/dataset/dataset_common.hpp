// Small helpers shared by the KITTI and DAIR-V2X-C runners: pose errors, timing, text files.
#pragma once

#include "v2xloc/algo/core/types.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace v2xloc::dataset {

// |t_est - t_ref| [m] and the angle of R_ref^T R_est [deg].
double translation_error_m(const Mat4d& estimate, const Mat4d& reference);
double rotation_error_deg(const Mat4d& estimate, const Mat4d& reference);
// Rotation angle of a (near-)rotation matrix [rad], acos clamped as the KITTI devkit does.
double rotation_angle_rad(const Mat3d& r);

// Thread CPU time [ns]: stage times comparable on a machine shared with other jobs.
std::uint64_t thread_cpu_ns();

// Regular files in `dir` whose name ends with `extension` (case-sensitive), sorted by name.
bool list_files(const std::string& dir, const std::string& extension, std::vector<std::string>& out,
                std::string& error);
bool is_directory(const std::string& path);
bool is_file(const std::string& path);

struct Stats {
  double mean = 0.0, median = 0.0, max = 0.0;
};
Stats stats_of(std::vector<double> values);  // zeros when empty

}  // namespace v2xloc::dataset
