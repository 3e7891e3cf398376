// The pose-search settings of the courtyard tests (robustness_test.cpp, pose_search_selection_test.cpp):
// a 4 m disc on a 1 m grid, 24 headings, 128 score points, ICP at 1 m then 0.3 m.
#pragma once

#include "v2xloc/algo/registration/pose_search.hpp"

namespace v2xloc::testing {

inline PoseSearchParams courtyard_search_params() {
  PoseSearchParams sp;
  sp.radius = 4.0;
  sp.step = 1.0;
  sp.yaw_steps = 24;
  sp.score_points = 128;
  sp.icp.max_correspondence_distance = 1.0;
  sp.fine_icp = sp.icp;
  sp.fine_icp.max_correspondence_distance = 0.3;
  return sp;
}

}  // namespace v2xloc::testing
