// The v2xloc-firmware command line (CLI11) and its --config file: --help lists every option, bad
// values and unknown keys are refused with a message and exit code 2 before any socket opens; a
// surveyed background the trust list names but cannot be loaded stops the start with a message.
// Host only: spawns the host-built executable.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <sys/wait.h>
#include <unistd.h>

#include "firmware/trust/background_file.hpp"
#include "firmware/trust/trust_list.hpp"

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

// Trust list dir/list.txt with one surveyed infrastructure unit (sender 1) whose background line
// names `name` with the SHA-256 of `vouched`.
std::string trust_list_with_background(const std::string& dir, const std::string& name,
                                       const std::vector<std::uint8_t>& vouched) {
  using namespace v2xloc::trust;
  TrustList l;
  TrustedSigner& s = l.signers[l.count++];
  const std::string seed = "cli background unit";
  derive_public_key(private_key_from_seed({reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()}), s.key);
  s.id = hashed_id8(s.key);
  s.role = SignerRole::kInfrastructure;
  s.sender_id = 1;
  s.surveyed = true;
  s.has_background = true;
  name.copy(s.background_file.data(), name.size());
  s.background_sha256 = sha256(vouched);
  std::string text(8192, '\0');
  text.resize(format_trust_list(l, {text.data(), text.size()}));
  std::ofstream(dir + "/list.txt") << text;
  return dir + "/list.txt";
}

std::vector<std::uint8_t> background_of(std::uint32_t sender) {
  const std::vector<std::uint32_t> keys = {5, 6, 9};
  std::vector<std::uint8_t> out(v2xloc::trust::background_file_bytes(keys.size()));
  v2xloc::trust::format_background(sender, 500'000, keys, out);
  return out;
}

void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

TEST(FirmwareCli, BackgroundThatCannotBeLoadedStopsTheStart) {
  const std::string dir = testing::TempDir() + "/v2xloc_fw_bg_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string args = "--emulated --origin 48.1,11.5,520 --cloud-port 0 --ego-port 0 --can-port 0 --trust-list ";
  const std::vector<std::uint8_t> good = background_of(1);
  std::vector<std::uint8_t> tampered = good;
  tampered.back() ^= 1;
  const struct {
    const char* what;
    std::vector<std::uint8_t> on_disk;  // empty: no file
    std::vector<std::uint8_t> vouched;
    const char* message;
  } cases[] = {
      {"missing", {}, good, "cannot read background"},
      {"tampered", tampered, good, "SHA-256 differs"},
      {"another unit's", background_of(2), background_of(2), "another sender id"},
      {"oversized", std::vector<std::uint8_t>(v2xloc::trust::kMaxBackgroundFileBytes + 4, 0), good, "too large"},
  };
  for (const auto& c : cases) {
    std::remove((dir + "/bg.bin").c_str());
    if (!c.on_disk.empty()) write_bytes(dir + "/bg.bin", c.on_disk);
    const ToolRun r = firmware(args + trust_list_with_background(dir, "bg.bin", c.vouched));
    EXPECT_EQ(r.exit_code, 1) << c.what << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.what << "\n" << r.out;
    EXPECT_NE(r.out.find("bg.bin"), std::string::npos) << "names the file: " << r.out;
    EXPECT_EQ(r.out.find("ready can="), std::string::npos) << c.what;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
