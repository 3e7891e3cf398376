// v2xloc-sim generate --scenario 0..3 --perm 4_infra_2_agent|4_infra|2_infra --out DIR [--seed N]
//                     [--duration S] [--quick]
// v2xloc-sim generate --all --out DIR [--seed N] [--duration S] [--quick]
// --all writes DIR/sim<k>_<perm>/ for all 12 combinations.
#include "host_sim/recording/recorder.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

int usage() {
  std::fprintf(stderr,
               "usage: v2xloc-sim generate --scenario 0..3 --perm 4_infra_2_agent|4_infra|2_infra --out DIR\n"
               "                           [--seed N] [--duration S] [--quick] [--no-stereo]\n"
               "       v2xloc-sim generate --all --out DIR [--seed N] [--duration S] [--quick] [--no-stereo]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace v2xloc::sim;
  if (argc < 2 || std::string(argv[1]) != "generate") return usage();
  RecorderConfig base;
  int scenario = -1;
  std::string perm_name;
  bool all = false;
  std::string out;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : nullptr; };
    if (a == "--all") {
      all = true;
    } else if (a == "--quick") {
      base.quick = true;
    } else if (a == "--no-stereo") {
      base.stereo = false;
    } else if (a == "--scenario") {
      const char* v = next();
      if (!v) return usage();
      scenario = std::atoi(v);
    } else if (a == "--perm") {
      const char* v = next();
      if (!v) return usage();
      perm_name = v;
    } else if (a == "--out") {
      const char* v = next();
      if (!v) return usage();
      out = v;
    } else if (a == "--seed") {
      const char* v = next();
      if (!v) return usage();
      base.seed = std::strtoull(v, nullptr, 10);
    } else if (a == "--duration") {
      const char* v = next();
      if (!v) return usage();
      base.duration = std::atof(v);
    } else {
      std::fprintf(stderr, "unknown argument %s\n", a.c_str());
      return usage();
    }
  }
  if (out.empty()) return usage();
  std::vector<RecorderConfig> jobs;
  if (all) {
    for (int s = 0; s < kScenarioCount; ++s)
      for (Permutation p : kAllPermutations) {
        RecorderConfig c = base;
        c.scenario = s;
        c.permutation = p;
        c.out_dir = out + "/" + recording_name(s, p);
        jobs.push_back(c);
      }
  } else {
    Permutation p;
    if (scenario < 0 || scenario >= kScenarioCount || !parse_permutation(perm_name, p)) return usage();
    RecorderConfig c = base;
    c.scenario = scenario;
    c.permutation = p;
    c.out_dir = out;
    jobs.push_back(c);
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<RecordingSummary> summaries;
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const std::string name = recording_name(jobs[j].scenario, jobs[j].permutation);
    int last_pct = -1;
    auto progress = [&](int done, int total) {
      const int pct = 100 * done / total;
      if (pct / 5 != last_pct / 5 || done == total) {
        std::fprintf(stderr, "\r[%zu/%zu] %-22s %3d%% (%d/%d frames)", j + 1, jobs.size(), name.c_str(), pct, done, total);
        std::fflush(stderr);
        last_pct = pct;
      }
    };
    RecordingSummary s;
    std::string error;
    if (!generate_recording(jobs[j], s, error, progress)) {
      std::fprintf(stderr, "\nerror: %s: %s\n", name.c_str(), error.c_str());
      return 1;
    }
    std::fprintf(stderr, "\n");
    summaries.push_back(s);
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const auto& s : summaries) std::printf("%s\n", s.one_line().c_str());
  if (summaries.size() > 1) std::printf("total: %zu recordings in %.1f s\n", summaries.size(), total);
  return 0;
}
