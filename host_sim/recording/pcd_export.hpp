// Standard PCD copies of a recording's clouds, for PCL, Open3D and viewers: format 2 stores them
// quantised (.pcdz), which those tools do not read.
#pragma once

#include "host_sim/cloud_io/pcd.hpp"
#include "host_sim/recording/recording_reader.hpp"

#include <cstdint>
#include <functional>
#include <string>

namespace v2xloc::sim {

struct PcdExportSummary {
  int clouds = 0;
  std::uint64_t bytes = 0;
};

// Writes every ego scan as OUT/ego_lidar/%06d.pcd and every map cloud at its manifest path under
// OUT with the extension .pcd: float32 x y z intensity t in `encoding` (binary_compressed is what
// PCL writes). `progress(done, total)` after each cloud. False with a message on the first error.
bool export_recording_pcd(const RecordingReader& reader, const std::string& out_dir, cloud_io::PcdEncoding encoding,
                          PcdExportSummary& summary, std::string& error,
                          const std::function<void(int, int)>& progress = {});

}  // namespace v2xloc::sim
