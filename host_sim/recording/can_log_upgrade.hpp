// Rewrites a recording's CAN log in the current CAN layout (v2xloc-sim upgrade-can). Readers
// convert a layout-1 log on the fly anyway; this makes the file itself what the DBC says, for
// tools that read it directly (candump players, python-can, cantools).
#pragma once

#include <cstddef>
#include <string>

#include "host_sim/canlog/can_layout.hpp"

namespace v2xloc::sim {

struct CanLogUpgrade {
  bool already_current = false;   // nothing to do: the manifest names the current layout
  std::string log_file;           // the log the manifest names now (relative to the recording)
  std::size_t frames = 0;         // frames in it
  CanLayoutConversion conversion;
};

// The original log is kept: the converted one is written beside it (<stem>_layout<N>.log), then the
// manifest, replaced in one rename, names it with can_log.layout_version (and can_log.converted_from
// the original), so an interrupted upgrade leaves a recording that still reads as before.
bool upgrade_can_log(const std::string& dir, CanLogUpgrade& result, std::string& error);

}  // namespace v2xloc::sim
