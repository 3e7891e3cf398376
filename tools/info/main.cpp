// v2xloc-info [--json]: every capacity / iteration cap of algo/include/v2xloc/algo/core/config.hpp and
// the static memory it implies (sizeof the workspace structs a firmware image keeps static).
#include "tools/info/config_table.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/registration/register_clouds.hpp"

// The localization stages' objects, when their headers exist (they hold fixed-size histories/maps).
#if __has_include("v2xloc/algo/localization/ekf.hpp")
#include "v2xloc/algo/localization/ekf.hpp"
#define V2XLOC_INFO_HAS_EKF 1
#endif
#if __has_include("v2xloc/algo/localization/map_fusion.hpp")
#include "v2xloc/algo/localization/map_fusion.hpp"
#define V2XLOC_INFO_HAS_MAP_FUSION 1
#endif
#if __has_include("v2xloc/algo/localization/odometry.hpp")
#include "v2xloc/algo/localization/odometry.hpp"
#define V2XLOC_INFO_HAS_ODOMETRY 1
#endif
#if __has_include("v2xloc/algo/localization/trajectory_backfill.hpp")
#include "v2xloc/algo/localization/trajectory_backfill.hpp"
#define V2XLOC_INFO_HAS_BACKFILL 1
#endif
#if __has_include("v2xloc/algo/localization/validity_gate.hpp")
#include "v2xloc/algo/localization/validity_gate.hpp"
#define V2XLOC_INFO_HAS_GATE 1
#endif

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

using v2xloc::RegistrationWorkspace;

struct MemoryEntry {
  const char* name;
  std::size_t bytes;
  bool part;  // a component of the entry above it (not added to the total)
};

std::vector<MemoryEntry> memory_entries() {
  using W = RegistrationWorkspace;
  std::vector<MemoryEntry> entries = {
      {"RegistrationWorkspace", sizeof(W), false},
      {"  voxel hash + output", sizeof(W::voxel), true},
      {"  downsampled clouds (2)", sizeof(W::source_down) + sizeof(W::target_down), true},
      {"  point k-d trees (2)", sizeof(W::source_tree) + sizeof(W::target_tree), true},
      {"  normals (2)", sizeof(W::source_normals) + sizeof(W::target_normals), true},
      {"  FPFH features + SPFH scratch", sizeof(W::source_features) + sizeof(W::target_features) +
                                             sizeof(W::spfh_scratch), true},
      {"  feature k-d trees (2)", sizeof(W::source_feature_tree) + sizeof(W::target_feature_tree), true},
      {"  correspondences + mutual scratch", sizeof(W::correspondences) + sizeof(W::mutual_scratch), true},
  };
#ifdef V2XLOC_INFO_HAS_MAP_FUSION
  entries.push_back({"MapFusion", sizeof(v2xloc::MapFusion), false});
  // Caller-owned: the firmware's BackgroundStore (firmware/wire/background_store.hpp).
  entries.push_back({"Surveyed background cells", v2xloc::config::kMaxBackgroundUnits *
                                                      v2xloc::config::kMaxBackgroundCells * sizeof(std::uint32_t), false});
#endif
#ifdef V2XLOC_INFO_HAS_ODOMETRY
  entries.push_back({"LidarOdometry", sizeof(v2xloc::LidarOdometry), false});
#endif
#ifdef V2XLOC_INFO_HAS_EKF
  entries.push_back({"Ekf", sizeof(v2xloc::Ekf), false});
#endif
#ifdef V2XLOC_INFO_HAS_GATE
  entries.push_back({"FixedLagValidityGate", sizeof(v2xloc::FixedLagValidityGate), false});
  entries.push_back({"CausalValidityGate", sizeof(v2xloc::CausalValidityGate), false});
#endif
#ifdef V2XLOC_INFO_HAS_BACKFILL
  entries.push_back({"TrajectoryBackfill", sizeof(v2xloc::TrajectoryBackfill), false});
#endif
  return entries;
}

std::string format_value(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

void print_text() {
  std::printf("v2xloc algo configuration (%s profile)\n\n",
              v2xloc::config::kEmbeddedProfile ? "EMBEDDED" : "default");
  const char* section = "";
  for (const auto& e : v2xloc::tools::config_entries()) {
    if (std::strcmp(section, e.section) != 0) {
      section = e.section;
      std::printf("%s\n", section);
    }
    std::printf("  %-28s %14s  %s\n", e.name, format_value(e.value).c_str(), e.comment);
  }
  std::printf("\nStatic memory (sizeof)\n");
  std::size_t total = 0;
  for (const auto& m : memory_entries()) {
    std::printf("  %-36s %12zu bytes  %9.2f MiB\n", m.name, m.bytes,
                static_cast<double>(m.bytes) / (1024.0 * 1024.0));
    if (!m.part) total += m.bytes;
  }
  std::printf("  %-36s %12zu bytes  %9.2f MiB\n", "total", total,
              static_cast<double>(total) / (1024.0 * 1024.0));
}

void print_json() {
  nlohmann::ordered_json out;  // keys in config.hpp's order
  out["profile"] = v2xloc::config::kEmbeddedProfile ? "embedded" : "default";
  nlohmann::ordered_json& config = out["config"] = nlohmann::ordered_json::object();
  for (const auto& e : v2xloc::tools::config_entries()) config[e.name] = e.value;
  nlohmann::ordered_json& memory = out["static_memory_bytes"] = nlohmann::ordered_json::object();
  std::size_t total = 0;
  for (const auto& m : memory_entries()) {
    if (m.part) continue;
    memory[m.name] = m.bytes;
    total += m.bytes;
  }
  memory["total"] = total;
  std::fputs((out.dump() + "\n").c_str(), stdout);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Capacities and iteration caps of algo/include/v2xloc/algo/core/config.hpp and the static memory\n"
               "they imply.",
               "v2xloc-info"};
  bool json = false;
  app.add_flag("--json", json, "one JSON object instead of the table");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // usage errors keep exit code 2
  }
  if (json) print_json();
  else print_text();
  return 0;
}
