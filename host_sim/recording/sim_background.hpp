// Surveyed backgrounds of the simulated infrastructure units, what an operator records at survey
// time: the unit's LiDAR swept over the static world only (buildings, street furniture, parked
// cars; no vehicle that moves), a few sweeps with their own noise merged, as voxel cells in the
// sensor frame (algo/.../surveyed_background.hpp). Each is written beside the trust list, which
// names the file with its SHA-256 (`background` line, firmware/trust/background_file.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "firmware/trust/trust_list.hpp"
#include "host_sim/sensors/lidar.hpp"
#include "host_sim/world/world.hpp"

namespace v2xloc::sim {

inline constexpr double kBackgroundCellM = 0.1;  // first cell edge tried; grown x 9/8 until the cells fit
inline constexpr int kBackgroundSweeps = 3;      // merged: dropouts of one sweep are filled by the others

struct SimBackground {
  std::uint32_t cell_um = 0;          // cell edge as the file stores it (the firmware keys with this)
  std::vector<std::uint32_t> cells;   // packed keys, ascending
  std::size_t returns = 0;            // rendered returns over all sweeps
  std::size_t outside = 0;            // returns outside the key span (left out)
  int coarsened = 0;                  // cell growths to fit max_cells
};

// "background_<sensor>.bin".
std::string background_file_name(const std::string& sensor);

// The unit's background: `static_world` must hold no dynamic bodies; noise from `seed` and the
// unit's index. Cells at kBackgroundCellM, grown until at most max_cells. False: no return in
// the key span (error set).
bool render_background(const World& static_world, const LidarConfig& cfg, const Eigen::Isometry3d& sensor_to_enu,
                       std::uint64_t seed, std::size_t unit, std::size_t max_cells, SimBackground& out,
                       std::string& error);

// The background of a unit's static returns `points` (sensor frame): cells at kBackgroundCellM,
// grown until at most max_cells. False: no point in the key span (error set).
bool background_from_points(const std::vector<Eigen::Vector3f>& points, std::size_t max_cells, SimBackground& out,
                            std::string& error);

// Writes `bg` as dir/background_file_name(sensor) and names it on `signer` (file + SHA-256).
bool write_background(const std::string& dir, const std::string& sensor, const SimBackground& bg,
                      trust::TrustedSigner& signer, std::string& error);

}  // namespace v2xloc::sim
