// Links the installed core: a rigid fit (algo), a CRC (protocol) and, on Linux, a HAL helper.
// The profile the package was built with must be the one the headers see (compile definition
// carried by v2xloc::algo). Prints one line and exits 0 when every check holds.
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "firmware/protocol/crc32.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/rigid_motion.hpp"
#include "v2xloc/algo/registration/kabsch.hpp"
#ifdef CONSUMER_HAS_HAL
#include "hal/status.hpp"
#endif

#if defined(EXPECTED_PROFILE_EMBEDDED)
static_assert(v2xloc::config::kEmbeddedProfile, "v2xloc::algo must carry V2XLOC_PROFILE_EMBEDDED");
#else
static_assert(!v2xloc::config::kEmbeddedProfile, "default profile expected");
#endif

namespace {

v2xloc::Vec3f g_source[8];
v2xloc::Vec3f g_target[8];

int run() {
  using namespace v2xloc;
  // Corners of a box moved by a known yaw and shift: Kabsch must recover them.
  Mat4d truth = Mat4d::Identity();
  truth.topLeftCorner<3, 3>() = rot_z(0.3);
  truth.topRightCorner<3, 1>() = Vec3d(1.0, -2.0, 0.5);
  for (int i = 0; i < 8; ++i) {
    const Vec3d p((i & 1) ? 2.0 : -1.0, (i & 2) ? 1.5 : -0.5, (i & 4) ? 3.0 : 0.0);
    g_source[i] = p.cast<float>();
    g_target[i] = (truth.topLeftCorner<3, 3>() * p + truth.topRightCorner<3, 1>()).cast<float>();
  }
  Mat4d fit = Mat4d::Identity();
  const RegistrationStatus status = kabsch_fit(g_source, g_target, {}, fit);
  const double error = (fit - truth).cwiseAbs().maxCoeff();
  const std::uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  const std::uint32_t crc = protocol::crc32(check);
  int failures = 0;
  if (status != RegistrationStatus::kOk || !(error < 1e-4)) ++failures;
  if (crc != 0xCBF43926u) ++failures;
#ifdef CONSUMER_HAS_HAL
  if (hal::to_string(hal::Status::kOk) == nullptr) ++failures;
#endif
  return failures;
}

}  // namespace

int main() {
  const int failures = run();
#ifndef CONSUMER_BAREMETAL
  std::printf("v2xloc consumer: %s (profile %s)\n", failures == 0 ? "ok" : "FAILED",
              v2xloc::config::kEmbeddedProfile ? "EMBEDDED" : "DEFAULT");
#endif
  return failures == 0 ? 0 : 1;
}
