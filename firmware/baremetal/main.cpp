// Bare-metal link check: runs every registration stage of algo/ on a tiny synthetic scene held
// in static storage (a box corner: floor and two walls, plus a transformed copy), so the linker
// proves the core needs no heap, no exceptions and no OS. Prints nothing; results go to a
// volatile sink so nothing is optimised away.
#include <cstdint>
#include <span>

#include "v2xloc/algo/config.hpp"
#include "v2xloc/algo/det_math.hpp"
#include "v2xloc/algo/kabsch.hpp"
#include "v2xloc/algo/prng.hpp"
#include "v2xloc/algo/register_clouds.hpp"

namespace {

constexpr std::size_t kScenePoints = 1536;
v2xloc::Vec3f g_target[kScenePoints];
v2xloc::Vec3f g_source[kScenePoints];
v2xloc::RegistrationWorkspace g_workspace;
volatile double g_sink;
volatile std::uint32_t g_status;

// Floor z=0, walls x=0 and y=0 over a 4 m cube corner, plus a pole; jittered by the PRNG.
void make_scene() {
  v2xloc::Pcg32 rng(2024);
  for (std::size_t i = 0; i < kScenePoints; ++i) {
    const double u = rng.uniform(0.0, 4.0), v = rng.uniform(0.0, 4.0);
    v2xloc::Vec3d p;
    switch (i % 4) {
      case 0: p = v2xloc::Vec3d(u, v, 0.0); break;
      case 1: p = v2xloc::Vec3d(0.0, u, v * 0.5); break;
      case 2: p = v2xloc::Vec3d(u, 0.0, v * 0.5); break;
      default: {
        const double a = rng.uniform(-v2xloc::det::kPi, v2xloc::det::kPi);
        p = v2xloc::Vec3d(2.0 + 0.1 * v2xloc::det::cos(a), 2.0 + 0.1 * v2xloc::det::sin(a), v * 0.5);
      }
    }
    g_target[i] = p.cast<float>();
  }
  // Source = T^-1 target with T a yaw of 0.3 rad and a 0.4 m shift.
  const double c = v2xloc::det::cos(0.3), s = v2xloc::det::sin(0.3);
  for (std::size_t i = 0; i < kScenePoints; ++i) {
    const v2xloc::Vec3d q = g_target[i].cast<double>() - v2xloc::Vec3d(0.4, -0.2, 0.0);
    g_source[i] = v2xloc::Vec3f(static_cast<float>(c * q.x() + s * q.y()),
                                static_cast<float>(-s * q.x() + c * q.y()), static_cast<float>(q.z()));
  }
}

}  // namespace

int main() {
  make_scene();
  const std::span<const v2xloc::Vec3f> source(g_source, kScenePoints);
  const std::span<const v2xloc::Vec3f> target(g_target, kScenePoints);

  // Global pipeline: downsample, k-d trees, normals, FPFH, correspondences, RANSAC, ICP.
  v2xloc::RegisterCloudsParams params;
  params.voxel_size = 0.2f;
  const v2xloc::RegisterCloudsResult global =
      v2xloc::register_clouds(source, target, params, v2xloc::Mat4d::Identity(), g_workspace);

  // ICP-only refinement (point-to-point with a robust kernel) from the global result.
  params.mode = v2xloc::RegistrationMode::kIcpOnly;
  params.icp.method = v2xloc::IcpMethod::kPointToPoint;
  params.icp.kernel.type = v2xloc::RobustKernelType::kTukey;
  const v2xloc::RegisterCloudsResult fine = v2xloc::register_clouds(
      source, target, params, global.registration.transform, g_workspace);

  v2xloc::Mat4d kabsch;
  const v2xloc::RegistrationStatus ks =
      v2xloc::kabsch_fit(source.first(64), target.first(64), {}, kabsch);

  g_status = static_cast<std::uint32_t>(global.registration.status) |
             (static_cast<std::uint32_t>(fine.registration.status) << 8) |
             (static_cast<std::uint32_t>(ks) << 16);
  g_sink = fine.registration.transform(0, 3) + kabsch(1, 3) + global.registration.fitness;
  for (;;) {
  }
}
