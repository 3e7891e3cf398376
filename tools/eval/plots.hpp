// PNG plots of one evaluated recording: top view (truth, fused, GNSS, registrations) and the
// fused error over time.
#pragma once

#include <string>
#include <vector>

#include "tools/eval/offline_run.hpp"

namespace v2xloc::eval {

bool write_top_view(const std::string& path, const std::vector<FrameRecord>& records, std::string& error);
bool write_error_plot(const std::string& path, const std::vector<FrameRecord>& records, std::string& error);

}  // namespace v2xloc::eval
