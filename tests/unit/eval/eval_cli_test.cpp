// The v2xloc-eval command line (CLI11): every option listed by --help, bad values refused with a
// message and exit code 2, and a short run whose --json report has the keys the scripts read.
// Host only: spawns the host-built v2xloc-sim and v2xloc-eval.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

const std::string kBin = std::string(V2XLOC_BINARY_DIR) + "/bin/";

struct ToolRun {
  int exit_code = -1;
  std::string out;  // stdout and stderr
};

ToolRun run(const std::string& command) {
  ToolRun r;
  std::FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

ToolRun eval(const std::string& args) { return run(kBin + "v2xloc-eval " + args); }

TEST(EvalCli, HelpListsEveryOption) {
  const ToolRun r = eval("--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"RECORDING_DIR", "--json", "--plots", "--estimates", "--trace", "--frames", "--gate",
                             "--no-gnss-gate", "--no-odometry", "--no-vehicle", "--no-gnss-heading", "--stereo",
                             "--quiet", "--timing", "--callgrind-dumps", "--firmware", "--faults"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option << "\n" << r.out;
}

TEST(EvalCli, BadValuesAreRefusedWithAMessageAndExitCode2) {
  const struct {
    const char* args;
    const char* message;
  } cases[] = {
      {"", "RECORDING_DIR is required"},
      {"rec --frames 0", "--frames"},
      {"rec --frames abc", "--frames"},
      {"rec --frames", "--frames"},
      {"rec --gate maybe", "--gate"},
      {"rec --faults loss=0.1", "--faults requires --firmware"},
      {"rec --firmware fw --faults loss=2", "--faults"},
      {"rec --firmware fw --faults bogus=1", "unknown fault"},
      {"rec --bogus", "--bogus"},
  };
  for (const auto& c : cases) {
    const ToolRun r = eval(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.args << "\n" << r.out;
  }
}

TEST(EvalCli, MissingRecordingIsAnErrorNamingIt) {
  const ToolRun r = eval("/nonexistent/v2xloc_rec --json");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("/nonexistent/v2xloc_rec"), std::string::npos) << r.out;
}

// A 1 s quick recording, 3 frames: the JSON report parses and has the keys tools and tests read.
TEST(EvalCli, JsonReportOfAShortRun) {
  const std::string dir = std::string(V2XLOC_BINARY_DIR) + "/test_tmp/eval_cli_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  const ToolRun gen = run(kBin + "v2xloc-sim generate --scenario 0 --perm 2_infra --quick --duration 1 --no-stereo --out " + dir);
  ASSERT_EQ(gen.exit_code, 0) << gen.out;
  const ToolRun r = run(kBin + "v2xloc-eval " + dir + " --frames 3 --json 2>/dev/null");
  // A surveyed background that does not match its trust-list digest stops the run with its name,
  // as it stops the firmware.
  std::string background;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().rfind("background_", 0) == 0) background = e.path().string();
  }
  ToolRun bad{};
  if (!background.empty()) {
    std::fstream f(background, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(40);
    f.put('\x5a');
    f.close();
    bad = run(kBin + "v2xloc-eval " + dir + " --frames 3 --json 2>&1");
  }
  std::filesystem::remove_all(dir);
  ASSERT_FALSE(background.empty()) << "the generated recording has surveyed backgrounds";
  EXPECT_NE(bad.exit_code, 0) << bad.out;
  EXPECT_NE(bad.out.find(std::filesystem::path(background).filename().string()), std::string::npos) << bad.out;
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out;
  ASSERT_EQ(j.at("rows").size(), 1u);
  const nlohmann::json& row = j["rows"][0];
  EXPECT_EQ(row.at("sim"), 0);
  EXPECT_EQ(row.at("perm"), "2_infra");
  EXPECT_EQ(row.at("frames"), 3);
  for (const char* key : {"valid_frames", "reg_ok_frames", "fused_max", "localizer_ms_per_frame",
                          "localizer_max_frame_ms"})
    EXPECT_TRUE(row.contains(key)) << key;
  for (const char* table : {"unaligned", "aligned"})
    for (const char* key : {"slam", "gps", "reg", "reg_valid", "fused", "fused_valid", "fused_ungated", "fused_lag", "gps_3d"})
      EXPECT_TRUE(row.at(table).contains(key)) << table << "." << key;
  EXPECT_TRUE(row["unaligned"]["gps"].is_number());
  // The recording's surveyed backgrounds are loaded in process too, and no genuine cloud fails them.
  EXPECT_EQ(row.at("work").at("backgrounds_loaded"), 2);
  EXPECT_EQ(row.at("work").at("map_background_mismatch"), 0);
}

}  // namespace
