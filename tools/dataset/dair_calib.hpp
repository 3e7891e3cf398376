// DAIR-V2X-C per-frame calibrations: where each LiDAR was in the dataset's local world frame.
// Reads ROOT/vehicle-side/data_info.json and ROOT/infrastructure-side/data_info.json (frame id =
// the point cloud's file stem; calib paths relative to the side's folder; numbers may be JSON
// strings, as the release writes time stamps) and the calib JSONs they name:
//   vehicle:  world_T_lidar = novatel_to_world * lidar_to_novatel   (both {"rotation", "translation"},
//             lidar_to_novatel wrapped in "transform")
//   roadside: world_T_lidar = virtuallidar_to_world, optionally with DAIR's system_error_offset
//             (delta_x, delta_y added to its world translation, as tools/dataset_converter/calib_i2v.py)
// The vehicle-from-roadside transform of a cooperative pair is then
//   T_i2v = inverse(world_T_vehicle_lidar) * world_T_roadside_lidar   (p_vehicle = T_i2v p_roadside).
// Side folders that are absent leave that side empty (lookups say so); malformed ones are errors.
#pragma once

#include "v2xloc/algo/core/types.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace v2xloc::dataset {

// DAIR's system_error_offset [m], world frame.
struct DairOffset {
  double delta_x = 0.0, delta_y = 0.0;
};

struct DairFrame {
  std::string id;                  // "015344"
  std::string pointcloud_path;     // joined with the side's folder
  std::int64_t timestamp_us = 0;   // pointcloud_timestamp [us] (0 when absent)
  std::vector<std::string> calib_paths;  // vehicle: novatel_to_world, lidar_to_novatel; roadside: virtuallidar_to_world
  std::string batch_id, intersection;    // batch_id, intersection_loc ("" when absent)
};

class DairCalib {
 public:
  // False with a message when a side's data_info.json exists but cannot be used.
  bool load(const std::string& root, std::string& error);

  // novatel_to_world and lidar_to_novatel of vehicle frame `vehicle_id`, as released.
  bool vehicle_calibs(const std::string& vehicle_id, Mat4d& world_T_novatel, Mat4d& novatel_T_lidar,
                      std::string& error) const;
  // novatel_to_world * lidar_to_novatel of vehicle frame `vehicle_id`.
  bool world_from_vehicle_lidar(const std::string& vehicle_id, Mat4d& world_T_lidar, std::string& error) const;
  // virtuallidar_to_world of roadside frame `roadside_id`, plus (offset.delta_x, offset.delta_y, 0)
  // on its translation (a zero offset: the calibration as released).
  bool world_from_roadside_lidar(const std::string& roadside_id, Mat4d& world_T_lidar, std::string& error,
                                 const DairOffset& offset = {}) const;
  // inverse(world_from_vehicle_lidar) * world_from_roadside_lidar(offset), composed in
  // calib_i2v.py's order with general 3x3 inverses.
  bool vehicle_from_roadside(const std::string& vehicle_id, const std::string& roadside_id, Mat4d& transform,
                             std::string& error, const DairOffset& offset = {}) const;

  const std::map<std::string, DairFrame>& vehicle_frames() const { return vehicle_; }
  const std::map<std::string, DairFrame>& roadside_frames() const { return roadside_; }

 private:
  std::map<std::string, DairFrame> vehicle_, roadside_;
};

// A JSON file, parsed without exceptions: false + "cannot open" / "not valid JSON" otherwise.
bool read_dair_json(const std::string& path, nlohmann::json& out, std::string& error);

// One DAIR calib JSON ({"rotation": 3x3, "translation": 3x1 or 3}, optionally under "transform")
// -> 4x4. Numbers may be strings. The rotation must be orthonormal within 1e-3, det > 0.
bool read_dair_transform(const std::string& path, Mat4d& transform, std::string& error);

// A JSON value as a finite double: a number or a string holding one.
bool dair_number(const nlohmann::json& value, double& out);

}  // namespace v2xloc::dataset
