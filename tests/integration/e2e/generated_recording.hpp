// A recording made by `v2xloc-sim generate` for one test suite, in a scratch folder under the
// system's temporary directory that goes with the object (host only: it runs the simulator CLI).
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace v2xloc::sim::test {

inline const std::string kBinDir = std::string(V2XLOC_BINARY_DIR) + "/bin/";

class GeneratedRecording {
 public:
  // `tag` names the scratch folder (with the process id), `args` the generate options besides --out.
  GeneratedRecording(const std::string& tag, const std::string& args)
      : dir_((std::filesystem::temp_directory_path() / (tag + "_" + std::to_string(getpid()))).string()) {
    std::filesystem::create_directories(dir_);
    const std::string cmd = kBinDir + "v2xloc-sim generate " + args + " --out " + path() + " > " + log() + " 2>&1";
    ok_ = std::system(cmd.c_str()) == 0;
  }
  ~GeneratedRecording() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  GeneratedRecording(const GeneratedRecording&) = delete;
  GeneratedRecording& operator=(const GeneratedRecording&) = delete;

  bool ok() const { return ok_; }
  std::string path() const { return dir_ + "/rec"; }
  std::string log() const { return dir_ + "/gen.log"; }

 private:
  std::string dir_;
  bool ok_ = false;
};

}  // namespace v2xloc::sim::test
