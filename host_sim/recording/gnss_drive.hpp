// The ego's GNSS over one scenario drive: the fixes the recorder writes to the CAN log, plus the
// truth-side statistics reported per recording (and checked against the paper's 8-17 m band).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "host_sim/gnss/gnss_simulator.hpp"
#include "host_sim/scenario/scenario.hpp"
#include "host_sim/world/world.hpp"
#include "v2xloc/algo/core/geodesy.hpp"

namespace v2xloc::sim {

struct GnssDrive {
  std::vector<GnssFix> fixes;                 // one per epoch (invalid ones included)
  std::vector<Eigen::Vector3d> true_antenna;  // ENU, same index as fixes
  std::vector<Eigen::Vector3d> true_velocity; // ENU m/s, same index
  int valid = 0;
  int velocity_valid = 0;
  double mean_velocity_error = 0.0, max_velocity_error = 0.0;  // horizontal, m/s
  double mean_h_error = 0.0, max_h_error = 0.0;
  double hdop_min = 0.0, hdop_max = 0.0;      // over valid fixes
};

// The GNSS noise stream of a recording: keyed by the scenario so each drive has its own draw.
std::uint64_t gnss_stream_seed(std::uint64_t recording_seed, int scenario_id);

// Fixes at rate_hz over the scenario, with the receiver configured for the scenario's recording
// time (Scenario::gnss_epoch_offset_s). Moves the world's clock; leaves it at t = 0.
GnssDrive simulate_gnss_drive(const Scenario& scenario, World& world, const v2xloc::GeodeticOrigin& origin,
                              std::uint64_t recording_seed, double rate_hz, const Eigen::Vector3d& antenna_in_body,
                              GnssConfig config = {});

}  // namespace v2xloc::sim
