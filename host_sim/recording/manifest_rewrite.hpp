// Changes a recording's manifest in place (the upgrade tools): read with the reader's size cap,
// edited as JSON, written to a temporary file and renamed over the old one, so a crash leaves
// either manifest, never half of one.
#pragma once

#include <functional>
#include <string>

#include "host_sim/recording/pose_io.hpp"

namespace v2xloc::sim {

// `edit` receives a manifest that has a "files" object (else: error, nothing written).
bool rewrite_manifest(const std::string& dir, const std::function<void(Json&)>& edit, std::string& error);

}  // namespace v2xloc::sim
