// v2xloc-dataset dair-v2x-c ROOT --recording OUT: one DAIR-V2X-C cooperative sequence as a v2xloc
// recording (host_sim/RECORDING_FORMAT.md), so that v2xloc-eval and the firmware replay a real drive
// with the code and defaults of the simulated rows.
//
// What goes where:
//   ego scans        vehicle-side/velodyne/*.pcd as recorded (sensor frame, per-point `timestamp`
//                    made relative to the scan's stamp); frame stamps from vehicle-side/data_info.json
//   body frame       the vehicle LiDAR's axes, origin on the ground below it (mount height measured
//                    from the first scan's ground returns)
//   ground truth     novatel_to_world * lidar_to_novatel (the NovAtel GNSS/INS), per scan; 100 Hz by
//                    interpolation
//   roadside shares  infrastructure-side/velodyne/*.pcd at their own stamps, sensor "infra_0", pose
//                    virtuallidar_to_world (+ system_error_offset, as DAIR-V2X's calib_i2v does),
//                    signed with the simulator's test key; its surveyed background from the cells
//                    its own sweeps return to in at least half of them (no survey is released)
//   GNSS             the simulator's urban-canyon receiver (host_sim/gnss) driven along the true
//                    antenna path through the simulated city: its street laid along the drive's first
//                    heading, the drive starting in the inner lane gnss_canyon_setback_m before the
//                    simulated intersection (the open crossing itself gives 1-5 m, not the canyon's
//                    8-17 m the paper degrades its fixes to); seeded, in the manifest
//   vehicle signals  wheel speed and yaw rate from the ground truth with host_sim/vehicle's noise
// Recording frame: DAIR's world frame shifted by `world_offset` (recording = world - offset) so the
// coordinates stay small; the manifest names the offset.
#pragma once

#include <cstdint>
#include <string>

namespace v2xloc::dataset {

struct DairRecordingOptions {
  std::string root;      // DAIR-V2X-C cooperative folder
  std::string out_dir;   // recording folder (created)
  std::string batch;     // vehicle-side batch_id to convert; empty: the folder must hold just one
  std::uint64_t seed = 1;             // GNSS and vehicle-signal noise
  bool system_error_offset = true;    // add cooperative/data_info.json's delta_x/y to the roadside pose
  double gnss_rate_hz = 5.0;
  double background_min_share = 0.2;  // a roadside cell is background when this share of its sweeps hit it
  // Constellation time of the drive [h after the simulator's epoch] and where it is laid in the
  // simulated city: the defaults put this example's fixes in the paper's 8-17 m band (12.4 m mean),
  // as the simulator's recording hours are chosen in it.
  double gnss_epoch_hour = 2.0;
  double gnss_canyon_setback_m = 50.0;  // [m] the drive's start before the simulated intersection
  double vehicle_rate_hz = 100.0;
  // Nominal geodetic origin of the recording frame (DAIR's world frame is not georeferenced in the
  // release): Beijing Yizhuang. It sets the satellites' geometry of the simulated receiver.
  double origin_lat_deg = 39.79, origin_lon_deg = 116.50, origin_alt_m = 30.0;
};

struct DairRecordingSummary {
  int frames = 0;
  int roadside_clouds = 0;
  double duration_s = 0.0;
  double first_roadside_s = 0.0;      // stamp of the first roadside cloud
  double lidar_height_m = 0.0;        // measured mount height
  double gnss_mean_h_error_m = 0.0, gnss_max_h_error_m = 0.0;
  int gnss_valid_fixes = 0;
  std::size_t background_cells = 0;
  std::size_t times_clamped = 0;      // per-point times outside [0, frame period) clamped
  std::string one_line() const;
};

bool write_dair_recording(const DairRecordingOptions& options, DairRecordingSummary& summary, std::string& error);

}  // namespace v2xloc::dataset
