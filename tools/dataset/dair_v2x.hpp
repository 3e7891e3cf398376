// v2xloc-dataset dair-v2x-c: registration of each infrastructure (roadside) cloud to its vehicle
// cloud on DAIR-V2X-C cooperative folders (Yu et al., "DAIR-V2X: A Large-Scale Dataset for
// Vehicle-Infrastructure Cooperative 3D Object Detection", CVPR 2022), from no prior or from a
// GNSS-grade prior, judged by its own evidence (registration_verdict.hpp) and scored against the
// dataset's vehicle-from-roadside transform.
// Accepted layout (paths in data_info.json are relative to ROOT, as in the release):
//   ROOT/cooperative/data_info.json   array of {"vehicle_pointcloud_path":
//       "vehicle-side/velodyne/015344.pcd", "infrastructure_pointcloud_path":
//       "infrastructure-side/velodyne/000009.pcd", "system_error_offset": {"delta_x": dx,
//       "delta_y": dy} (numbers or numeric strings; "" = none), optional "calib_lidar_i2v_path",
//       other fields ignored}
//   ROOT/vehicle-side/velodyne/*.pcd, ROOT/infrastructure-side/velodyne/*.pcd
//   The reference, per pair:
//   - ROOT/cooperative/calib/lidar_i2v/<vehicle id>.json where present   {"rotation": 3x3 rows,
//       "translation": [[x],[y],[z]] (or [x,y,z])}, optionally wrapped in {"transform": {...}};
//       maps infrastructure-LiDAR points into the vehicle-LiDAR frame: p_v = R p_i + t; the
//       offset-corrected reference adds (delta_x, delta_y, 0) to its translation;
//   - otherwise computed from the per-frame calibrations as DAIR-V2X's calib_i2v.py does
//       (dair_calib.hpp: vehicle-side/ and infrastructure-side/ data_info.json and calib/); the
//       offset-corrected reference adds the offset to the roadside's world translation first.
//   The dataset's transform is the offset-corrected one; success ("within the floor") is judged
//   against it.
// Entries whose point clouds are absent are skipped (counted): a folder may hold just some pairs.
#pragma once

#include "v2xloc/algo/registration/register_clouds.hpp"
#include "v2xloc/algo/registration/registration_verdict.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

namespace v2xloc::dataset {

struct DairPair {
  std::string vehicle_id, infrastructure_id;   // file stems ("015344")
  std::string vehicle_path, infrastructure_path, calib_path;  // absolute or ROOT-relative joined
  double delta_x = 0.0, delta_y = 0.0;         // system_error_offset (0 when absent)
  bool has_offset = false;
};

// Reads ROOT/cooperative/data_info.json. `pairs` holds the entries whose two clouds exist;
// `missing` counts the others. False with a message when the layout or the JSON is wrong.
bool read_dair_pairs(const std::string& root, std::vector<DairPair>& pairs, std::size_t& missing,
                     std::string& error);
// lidar_i2v JSON -> 4x4 (p_vehicle = T p_infrastructure).
bool read_lidar_i2v(const std::string& path, Mat4d& transform, std::string& error);

enum class DairPrior : std::uint8_t { kNone, kGnss };

struct DairOptions {
  std::string root;
  // [m] register_clouds voxel. 1 m, not the core's 0.5 m default: on the simulated pairs 0.5 m
  // matched repeated structure (the intersection is nearly symmetric) on all three pairs, 1 m
  // registered all three within 1.1 cm / 0.015 deg; whole-scene pairs tens of metres apart
  // need coarse, distinctive features.
  float voxel = 1.0f;
  RegistrationMode mode = RegistrationMode::kGlobal;  // global (FPFH + RANSAC + ICP), search, icp
  std::optional<std::uint64_t> seed;  // RANSAC seed
  std::size_t limit = 0;              // 0 = all pairs
  // Summary: a pair is "within the floor" this close to the dataset's (offset-corrected)
  // transform; the dataset's own vehicle-to-roadside calibration is good to about 1 m / 2 deg.
  double success_translation_m = 2.0;
  double success_rotation_deg = 2.0;
  // GNSS-grade prior: the dataset's transform with the vehicle's pose moved by prior_translation_m
  // (horizontal, direction drawn per pair) and turned by +-prior_yaw_deg (sign drawn), seeded.
  // Mode search searches around it, mode icp starts from it; mode global ignores it.
  DairPrior prior = DairPrior::kNone;
  double prior_translation_m = 3.0;
  double prior_yaw_deg = 3.0;
  std::uint64_t prior_seed = 1;
  VerdictParams verdict{};
};

// The prior of pair number `index`: inverse(delta) * reference, delta = [Rz(+-yaw) | d], |d| =
// translation (horizontal), drawn from (seed, index) by SplitMix64 (same on every machine).
Mat4d dair_gnss_prior(const Mat4d& reference, double translation_m, double yaw_deg, std::uint64_t seed,
                      std::size_t index);

struct DairPairResult {
  DairPair pair;
  std::string status;      // "ok", "unreliable", registration failure name, or "error"
  std::string message;     // for "error"
  std::string reference_source;  // "lidar_i2v" or "computed" (per-frame calibrations)
  RegistrationVerdict verdict{};
  Mat4d estimate = Mat4d::Identity();
  Mat4d reference = Mat4d::Identity();            // as given (computed: without the offset)
  Mat4d reference_corrected = Mat4d::Identity();  // the dataset's transform (offset applied)
  Mat4d prior = Mat4d::Identity();                // the GNSS-grade prior (when used)
  double translation_error_m = 0.0, rotation_error_deg = 0.0;   // vs reference as given
  double translation_error_corrected_m = 0.0;                   // vs the dataset's transform
  double rotation_error_corrected_deg = 0.0;
  double prior_translation_error_m = 0.0, prior_rotation_error_deg = 0.0;  // prior vs dataset's
  bool within_floor = false;  // vs the dataset's transform, success thresholds
  double fitness = 0.0, inlier_rmse = 0.0;
  double ms = 0.0;          // register_clouds, thread CPU
  double read_ms = 0.0;
  std::size_t vehicle_points = 0, infrastructure_points = 0;
};

struct DairRunResult {
  std::vector<DairPairResult> pairs;
  std::size_t skipped_missing = 0;
};

// False only when the folder cannot be used at all; per-pair problems are per-pair statuses.
bool run_dair(const DairOptions& options, DairRunResult& result, std::string& error);

// Counts over a run: verdicts, success within the floor, and how often "ok" is wrong.
struct DairSummary {
  std::size_t pairs = 0, skipped_missing = 0;
  std::size_t ok = 0, unreliable = 0, failed = 0, errors = 0;
  std::size_t within_floor = 0;             // any verdict but failed
  std::size_t ok_within_floor = 0, ok_wrong = 0, unreliable_within_floor = 0;
  std::vector<double> translation_error, rotation_error;  // ok pairs, vs the dataset's transform
  std::vector<double> ms;                                 // pairs that ran
};
DairSummary dair_summary(const DairOptions& options, const DairRunResult& result);
// Why a run has no ok pair (for the exit message).
std::string dair_nothing_registered(const DairRunResult& result);

nlohmann::ordered_json dair_json(const DairOptions& options, const DairRunResult& result);
std::string dair_table(const DairOptions& options, const DairRunResult& result);

}  // namespace v2xloc::dataset
