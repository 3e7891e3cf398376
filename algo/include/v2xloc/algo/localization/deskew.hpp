// Motion compensation of a rotating-LiDAR sweep (KISS-ICP, Vizzo et al. 2023, Sec. III-A):
// the sensor moves during the sweep, so each point is expressed in the sensor frame at its own
// time t_i. Under a constant-velocity model, the previous frame's relative motion
// delta = T_{k-1}^-1 T_k over delta_duration seconds gives the twist xi = log(delta) / duration,
// and the pose at t_i relative to the reference time is exp(xi (t_i - t_ref)). Each point is
// mapped to p' = exp(xi (t_i - t_ref)) p_i, i.e. into the sensor frame at t_ref.
#pragma once

#include <cstdint>
#include <span>

#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

struct DeskewParams {
  double reference_time = 0.0;  // [s] time of the output frame, same clock as the point times
  double delta_duration = 0.1;  // [s] duration the relative motion `delta` spans (frame period)
};

enum class DeskewStatus : std::uint8_t {
  kOk,
  kInvalidInput,  // times.size() != points.size(), delta not finite, duration <= 0
  kTruncated,     // output buffer smaller than the finite points: the rest dropped (counted)
};

struct DeskewResult {
  DeskewStatus status = DeskewStatus::kInvalidInput;
  std::uint32_t points_out = 0;
  std::uint32_t non_finite_dropped = 0;  // NaN/Inf coordinate or time
  std::uint32_t capacity_dropped = 0;
};

// Writes the compensated finite points, in input order, to out[0, points_out).
// points and out must not overlap unless they are the same span (in-place is allowed).
DeskewResult deskew(std::span<const Vec3f> points, std::span<const float> times,
                    const Mat4d& delta, const DeskewParams& params, std::span<Vec3f> out);

}  // namespace v2xloc
