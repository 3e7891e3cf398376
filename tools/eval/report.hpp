// Table 1 in the paper's layout with our numbers beside the paper's, and the JSON report.
#pragma once

#include <string>
#include <vector>

#include "tools/eval/metrics.hpp"

namespace v2xloc::eval {

struct RowReport {
  int sim = -1;
  std::string permutation;
  std::string dir;
  RowMetrics metrics;
  RunStats stats;
};

std::string format_table(const std::vector<RowReport>& rows, bool aligned);
// Per-row period timing (rows run with --timing), empty otherwise.
std::string format_timing(const std::vector<RowReport>& rows);
std::string format_json(const std::vector<RowReport>& rows);

}  // namespace v2xloc::eval
