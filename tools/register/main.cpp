// v2xloc-register SOURCE TARGET [--voxel M] [--init FILE_4x4] [--mode global|icp|search] [--seed N]
// Reads two clouds, runs the allocation-free registration pipeline (algo/register_clouds) and
// prints one JSON object with its verdict (see register_cli.hpp). Exit 0 verdict ok, 1 unreliable
// or failed, 2 usage/IO.
#include "host_sim/cloud_io/cloud_io.hpp"
#include "tools/register/register_cli.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>

namespace {

std::uint64_t steady_ns() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

double ms_since(std::uint64_t start_ns) { return static_cast<double>(steady_ns() - start_ns) * 1e-6; }

// Stage times are CPU time of this (single) thread: comparable with Open3D's process_time on a
// machine shared with other jobs (wall time would count their load).
std::uint64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

// Several tens of MB: static, never on the stack.
v2xloc::RegistrationWorkspace g_workspace;
v2xloc::LevelSearchWorkspace g_search_workspace;

}  // namespace

int main(int argc, char** argv) {
  using namespace v2xloc;
  tools::RegisterOptions options;
  std::string error;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() == 1 && (args[0] == "-h" || args[0] == "--help")) {
    std::fputs(tools::register_usage(), stdout);
    return 0;
  }
  if (!tools::parse_register_args(args, options, error)) {
    std::fprintf(stderr, "v2xloc-register: %s\n%s", error.c_str(), tools::register_usage());
    return 2;
  }

  Mat4d initial = Mat4d::Identity();
  if (options.init_path && !tools::read_matrix4(*options.init_path, initial, error)) {
    std::fprintf(stderr, "v2xloc-register: %s\n", error.c_str());
    return 2;
  }

  tools::RegisterTimings timings;
  cloud_io::PointCloud source, target;
  std::uint64_t t0 = steady_ns();
  if (!cloud_io::read_cloud(options.source_path, source, error)) {
    std::fprintf(stderr, "v2xloc-register: %s\n", error.c_str());
    return 2;
  }
  timings.read_source_ms = ms_since(t0);
  t0 = steady_ns();
  if (!cloud_io::read_cloud(options.target_path, target, error)) {
    std::fprintf(stderr, "v2xloc-register: %s\n", error.c_str());
    return 2;
  }
  timings.read_target_ms = ms_since(t0);

  RegisterCloudsParams params = tools::register_params(options);
  if (source.has_viewpoint) params.source_viewpoint = source.sensor_origin;
  if (target.has_viewpoint) params.target_viewpoint = target.sensor_origin;
  params.clock = &thread_cpu_ns;

  t0 = thread_cpu_ns();
  const RegisterCloudsResult result =
      register_clouds(source.points, target.points, params, initial, g_workspace, g_search_workspace);
  timings.registration_ms = static_cast<double>(thread_cpu_ns() - t0) * 1e-6;
  for (int i = 0; i < static_cast<int>(RegisterStage::kCount); ++i) {
    timings.stage_ms[i] = static_cast<double>(result.stats.ticks[i]) * 1e-6;  // ticks are ns
  }

  const VerdictParams verdict_params;
  const RegistrationVerdict verdict = judge_registration(
      result.registration, result.runner_up.ok() ? &result.runner_up : nullptr, verdict_params);
  std::fputs(tools::register_json(options, params, result, timings, verdict, verdict_params).c_str(), stdout);
  return verdict.verdict == Verdict::kOk ? 0 : 1;
}
