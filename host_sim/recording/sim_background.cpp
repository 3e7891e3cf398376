#include "host_sim/recording/sim_background.hpp"

#include <algorithm>
#include <cmath>

#include "firmware/trust/background_file.hpp"
#include "host_sim/common/rng.hpp"
#include "host_sim/common/text_file.hpp"
#include "v2xloc/algo/localization/surveyed_background.hpp"

namespace v2xloc::sim {
namespace {

// Noise stream of the survey sweeps (derive_seed key; recorder.cpp's sensor streams are 1-7).
constexpr std::uint64_t kBackgroundStream = 8;

// Distinct cell keys of `points` at cell_um, ascending; counts the points outside the key span.
std::vector<std::uint32_t> cell_keys(const std::vector<Eigen::Vector3f>& points, std::uint32_t cell_um,
                                     std::size_t& outside) {
  const double inv_cell = 1.0 / (static_cast<double>(cell_um) * 1e-6);  // the firmware's expression
  std::vector<std::uint32_t> keys;
  keys.reserve(points.size());
  outside = 0;
  for (const Eigen::Vector3f& p : points) {
    std::uint32_t key = 0;
    if (background_cell_key(p, inv_cell, key)) {
      keys.push_back(key);
    } else {
      ++outside;
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

}  // namespace

std::string background_file_name(const std::string& sensor) { return "background_" + sensor + ".bin"; }

bool render_background(const World& static_world, const LidarConfig& cfg, const Eigen::Isometry3d& sensor_to_enu,
                       std::uint64_t seed, std::size_t unit, std::size_t max_cells, SimBackground& out,
                       std::string& error) {
  out = SimBackground{};
  std::vector<Eigen::Vector3f> points;
  LidarScan scan;
  for (int k = 0; k < kBackgroundSweeps; ++k) {
    Rng rng(derive_seed(seed, {kBackgroundStream, unit, static_cast<std::uint64_t>(k)}));
    render_lidar_sweep(static_world, cfg, [&](double) { return sensor_to_enu; }, 0.0, -1, rng, scan);
    for (const LidarPoint& p : scan.points) points.push_back(p.p);
  }
  if (!background_from_points(points, max_cells, out, error)) {
    error = cfg.name + ": " + error;
    return false;
  }
  return true;
}

bool background_from_points(const std::vector<Eigen::Vector3f>& points, std::size_t max_cells, SimBackground& out,
                            std::string& error) {
  out = SimBackground{};
  out.returns = points.size();
  // Finest cell first; a scene with more cells than the firmware holds gets coarser cells, not
  // fewer (a thinned background would leave genuine points without their cell).
  double cell = kBackgroundCellM;
  for (;; ++out.coarsened) {
    out.cell_um = static_cast<std::uint32_t>(std::lround(cell * 1e6));
    out.cells = cell_keys(points, out.cell_um, out.outside);
    if (out.cells.size() <= max_cells || cell * 1.125 > kBackgroundMaxCell) break;
    cell *= 1.125;
  }
  if (out.cells.empty() || out.cells.size() > max_cells) {
    error = "background has " + std::to_string(out.cells.size()) + " cells (want 1.." + std::to_string(max_cells) + ")";
    return false;
  }
  return true;
}

bool write_background(const std::string& dir, const std::string& sensor, const SimBackground& bg,
                      trust::TrustedSigner& signer, std::string& error) {
  std::string bytes(trust::background_file_bytes(bg.cells.size()), '\0');
  const std::span<std::uint8_t> out(reinterpret_cast<std::uint8_t*>(bytes.data()), bytes.size());
  if (trust::format_background(signer.sender_id, bg.cell_um, bg.cells, out) != bytes.size()) {
    error = sensor + ": background does not fit the file format";
    return false;
  }
  const std::string name = background_file_name(sensor);
  if (name.size() > trust::kMaxBackgroundNameChars) {
    error = sensor + ": background file name too long";
    return false;
  }
  if (!write_text_file(dir + "/" + name, bytes, error)) return false;
  signer.has_background = true;
  signer.background_file = {};
  name.copy(signer.background_file.data(), name.size());
  signer.background_sha256 = trust::sha256(out);
  return true;
}

}  // namespace v2xloc::sim
