// The recording's CAN log (gnss_vehicle.log): vehicle motion samples and GNSS fixes as the frames
// of CAN layout 2 (tools/dbc/v2xloc.dbc), merged in time order, candump -L time stamps =
// time_origin_unix_s + t. Shared by the simulator's recorder and the dataset converters.
#pragma once

#include <span>
#include <string>

#include "host_sim/gnss/gnss_simulator.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/vehicle/vehicle_signals.hpp"

namespace v2xloc::sim {

// Writes `path`; `can_json` receives the manifest's can_log entry (file name `file_name`).
bool write_gnss_vehicle_can_log(const std::string& path, const std::string& file_name, double time_origin_unix_s,
                                std::span<const VehicleSignals> vehicle, std::span<const GnssFix> fixes,
                                Json& can_json, std::string& error);

}  // namespace v2xloc::sim
