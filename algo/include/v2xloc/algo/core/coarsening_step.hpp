// Where to start coarsening a cloud that overflowed last time: a sensor's clouds of one scene hold
// nearly the same number of voxels, so re-reading from the base voxel would only prove the finer
// steps overflow again. Shared by the scan ingest (x 81/64 voxels per step finer: 9/8 edges, the
// surface law) and the map fusion (x 2 per step finer: doubled edges, as measured).
#pragma once

#include <cstdint>

namespace v2xloc {

// The finest step, at most last_step (and max_steps), at which last_voxels, times growth per step
// finer, still fit capacity.
inline std::uint32_t finest_fitting_step(std::uint32_t last_step, std::uint32_t max_steps, double last_voxels,
                                         double growth, double capacity) {
  std::uint32_t step = last_step < max_steps ? last_step : max_steps;
  double finer = last_voxels * growth;
  while (step > 0 && finer <= capacity) {
    --step;
    finer *= growth;
  }
  return step;
}

}  // namespace v2xloc
