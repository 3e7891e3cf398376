// Test-side helpers for the registration tests (host code: std::vector allowed here).
//   - a deterministic urban-like synthetic scene (ground with curbs, facades with setbacks,
//     poles, parked cars) sampled from two sensor positions with 2 cm noise,
//   - minimal PLY (binary little-endian / ascii) and ASCII PCD readers (x, y, z only),
//   - transform helpers and error metrics.
// Every random number comes from Pcg32 and every angle from det::sin/cos, so the generated
// clouds have the same bits on x86-64 and aarch64 (the golden test depends on that).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "v2xloc/algo/core/prng.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc::testing {

struct UrbanSceneOptions {
  double sensor_range = 25.0;        // [m] points kept within this distance of the sensor
  double sensor_separation = 10.0;   // [m] source sensor vs target sensor (overlap ~ 60-80 %)
  double ground_density = 6.0;       // points per m^2
  double structure_density = 12.0;   // points per m^2 on facades, poles, cars
  double noise_sigma = 0.02;         // [m] per axis (Irwin-Hall approximation of a Gaussian)
};

struct CloudPair {
  std::vector<Vec3f> source;   // in the source sensor frame
  std::vector<Vec3f> target;   // in the target (world) frame
  Mat4d target_from_source = Mat4d::Identity();  // ground truth: p_target = T p_source
  double overlap = 0.0;        // fraction of source points within 0.1 m... of the target's region
};

// scene_seed selects the world (layout of buildings, poles, cars); sample_seed the point noise.
// The source cloud is expressed in a frame such that target_from_source == T.
CloudPair make_urban_pair(std::uint64_t scene_seed, std::uint64_t sample_seed, const Mat4d& T,
                          const UrbanSceneOptions& options = {});

// Random rigid transform: yaw uniform in [-max_yaw, max_yaw] [rad], roll/pitch in
// [-max_tilt, max_tilt], translation uniform in a disc/ball of radius max_translation [m].
Mat4d random_transform(Pcg32& rng, double max_yaw, double max_tilt, double max_translation);
Mat4d rotation_zyx(double yaw, double pitch, double roll, const Vec3d& t);

double translation_error(const Mat4d& estimate, const Mat4d& truth);   // [m]
double rotation_error_deg(const Mat4d& estimate, const Mat4d& truth);  // [deg]

std::vector<Vec3f> transform_cloud(const std::vector<Vec3f>& cloud, const Mat4d& T);

// Readers return false (with a message) on anything they do not understand.
bool read_ply_xyz(const std::string& path, std::vector<Vec3f>& points, std::string& error);
bool read_pcd_ascii_xyz(const std::string& path, std::vector<Vec3f>& points, std::string& error);
// 4x4 row-major, '#' comment lines skipped.
bool read_matrix4(const std::string& path, Mat4d& m, std::string& error);

bool file_exists(const std::string& path);

}  // namespace v2xloc::testing
