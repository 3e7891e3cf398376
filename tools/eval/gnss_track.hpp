// The GPS column's input, the same for the in-process and the firmware path: the latest valid fix
// of the recording's CAN log with t <= each frame's time, in ENU minus the GNSS lever arm.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "host_sim/recording/recording_reader.hpp"
#include "tools/eval/offline_run.hpp"

namespace v2xloc::eval {

// Sets has_gnss and gnss_body of `records` (their t already set, ascending). False + error when
// the CAN log cannot be read.
bool fill_gnss(const sim::RecordingReader& reader, const Eigen::Vector3d& gnss_antenna_in_body,
               std::vector<FrameRecord>& records, std::string& error);

}  // namespace v2xloc::eval
