// The paper's Table 1 (Chao, Rasshofer, Knoll 2025): average distance between aligned estimated
// and ground-truth trajectories, metres. Printed beside our numbers by v2xloc-eval.
#pragma once

#include <array>
#include <string_view>

namespace v2xloc::sim {

struct PaperRow {
  int sim;
  std::string_view permutation;
  double slam, gps, reg, reg_valid, fused, fused_valid;
};

inline constexpr std::array<PaperRow, 12> kPaperTable1 = {{
    {0, "4_infra_2_agent", 0.164, 7.988, 3.929, 1.046, 1.634, 0.016},
    {0, "4_infra", 0.164, 7.988, 3.615, 0.875, 0.019, 0.016},
    {0, "2_infra", 0.164, 7.988, 2.525, 0.565, 0.019, 0.016},
    {1, "4_infra_2_agent", 0.145, 11.203, 2.715, 2.330, 0.021, 0.020},
    {1, "4_infra", 0.145, 11.203, 1.488, 0.996, 0.028, 0.028},
    {1, "2_infra", 0.145, 11.203, 2.101, 1.903, 0.019, 0.019},
    {2, "4_infra_2_agent", 0.093, 16.967, 5.252, 4.225, 0.019, 0.014},
    {2, "4_infra", 0.093, 16.967, 32.530, 32.697, 0.021, 0.020},
    {2, "2_infra", 0.093, 16.967, 5.796, 3.200, 0.016, 0.012},
    {3, "4_infra_2_agent", 0.102, 14.541, 3.275, 1.864, 0.016, 0.015},
    {3, "4_infra", 0.102, 14.541, 8.658, 0.043, 0.019, 0.012},
    {3, "2_infra", 0.102, 14.541, 6.989, 0.026, 0.023, 0.009},
}};

inline const PaperRow* find_paper_row(int sim, std::string_view permutation) {
  for (const auto& row : kPaperTable1) {
    if (row.sim == sim && row.permutation == permutation) return &row;
  }
  return nullptr;
}

}  // namespace v2xloc::sim
