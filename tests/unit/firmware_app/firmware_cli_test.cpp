// The v2xloc-firmware command line (CLI11) and its --config file: --help lists every option, bad
// values and unknown keys are refused with a message and exit code 2 before any socket opens.
// Host only: spawns the host-built executable.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

const std::string kFirmware = std::string(V2XLOC_BINARY_DIR) + "/bin/v2xloc-firmware";

struct ToolRun {
  int exit_code = -1;
  std::string out;  // stdout and stderr
};

ToolRun firmware(const std::string& args) {
  ToolRun r;
  std::FILE* pipe = popen((kFirmware + " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string config_file(const std::string& text) {
  const std::string path = testing::TempDir() + "/v2xloc_fw_" + std::to_string(::getpid()) + ".cfg";
  std::ofstream(path) << text;
  return path;
}

TEST(FirmwareCli, HelpListsEveryOption) {
  const ToolRun r = firmware("--help");
  EXPECT_EQ(r.exit_code, 0);
  for (const char* option : {"--config", "--emulated", "--origin", "--cloud-port", "--cloud-bind", "--ego-port",
                             "--ego-bind", "--trust-list", "--epoch-ns", "--max-frames", "--rcvbuf", "--can-iface",
                             "--can-bring-up", "--pps-chip", "--pps-line", "--led-chip", "--led-line", "--can-port",
                             "--can-peer-port", "--pps", "ready can=PORT"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option << "\n" << r.out;
}

TEST(FirmwareCli, BadValuesAreRefusedWithAMessageAndExitCode2) {
  const struct {
    const char* args;
    const char* message;
  } cases[] = {
      {"--emulated", "--origin: LAT,LON,ALT is required"},
      {"--emulated --origin 48.1,11.5", "three numbers"},
      {"--emulated --origin 48.1,11.5,x", "--origin"},
      {"--emulated --origin 95,11.5,520", "latitude within"},
      {"--emulated --origin 48.1,11.5,520 --cloud-port 70000", "--cloud-port"},
      {"--emulated --origin 48.1,11.5,520 --can-port -1", "--can-port"},
      {"--emulated --origin 48.1,11.5,520 --cloud-bind 1.2.3", "IPv4"},
      {"--emulated --origin 48.1,11.5,520 --rcvbuf 0", "--rcvbuf"},
      {"--emulated --origin 48.1,11.5,520 --pps 2", "--pps"},
      {"--emulated --origin 48.1,11.5,520 --max-frames -3", "--max-frames"},
      {"--emulated --origin 48.1,11.5,520 --frobnicate 1", "--frobnicate"},
      {"--config /nonexistent/v2xloc.cfg", "/nonexistent/v2xloc.cfg"},
  };
  for (const auto& c : cases) {
    const ToolRun r = firmware(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.args << "\n" << r.out;
    EXPECT_EQ(r.out.find("ready can="), std::string::npos) << c.args;
  }
}

TEST(FirmwareCli, ConfigFileKeysAreCheckedAndTheCommandLineWins) {
  // The config's origin is read (and refused here for its latitude) ...
  std::string path = config_file("# ECU\norigin=95,11.5,520\nemulated=1\n");
  ToolRun r = firmware("--config " + path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("latitude within"), std::string::npos) << r.out;
  // ... unless the command line gives one (here too short, which names the command line's value).
  r = firmware("--config " + path + " --origin 1,2");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("three numbers"), std::string::npos) << r.out;
  // A key the firmware does not know is an error, not silently ignored.
  path = config_file("origin=48.1,11.5,520\ncloud_prot=47200\n");
  r = firmware("--config " + path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("cloud_prot"), std::string::npos) << r.out;
  std::remove(path.c_str());
}

}  // namespace
