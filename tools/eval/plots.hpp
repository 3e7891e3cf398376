// Plots of one evaluated recording, drawn by matplotlib (tools/plots/plot_run.py) from files the
// evaluator writes next to them: DIR/<name>_frames.csv (per frame: truth, GNSS fix, odometry,
// registration, fused pose, gate decision and each Table 1 column's error) and DIR/<name>_map.csv
// (the reference map's points in ENU).
#pragma once

#include <string>
#include <vector>

#include "host_sim/recording/recording_reader.hpp"
#include "tools/eval/offline_run.hpp"

namespace v2xloc::eval {

// Per-frame CSV; errors are unaligned (what the vehicle lives with) and as compute_metrics counts
// them, so a column's mean is the table's value. "nan" where a column does not cover the frame.
bool write_plot_frames(const std::string& path, const std::vector<FrameRecord>& records, std::string& error);

// The map clouds published at the first stamp (every infrastructure sensor and agent), in ENU
// through their reported poses, thinned to one point per 0.2 m cell (the highest): "x,y,z" CSV.
bool write_map_points(const std::string& path, const sim::RecordingReader& reader, std::string& error);

// Both of the above as DIR/<name>_frames.csv and DIR/<name>_map.csv.
bool write_plot_data(const std::string& dir, const std::string& name, const sim::RecordingReader& reader,
                     const std::vector<FrameRecord>& records, std::string& error);

struct PlotRender {
  bool ok = false;       // the script ran and wrote the plots
  bool skipped = false;  // no python3 / matplotlib / script: plot data kept, no pictures
  std::string message;
};

// Runs plot_run.py over `dir` (every *_frames.csv in it); `trace_dir` (may be empty) adds the
// per-frame timing plot when the trace has timing columns. The interpreter is $V2XLOC_PYTHON or
// /usr/bin/python3, the script $V2XLOC_PLOT_SCRIPT or the source tree's tools/plots/plot_run.py.
PlotRender render_plots(const std::string& dir, const std::string& trace_dir);

}  // namespace v2xloc::eval
