// Recording metadata: manifest.json (first byte even) or a TUM trajectory (odd). The manifest
// either parses into checked values (file names built from its patterns stay plain relative
// paths) or fails with a message; TUM poses come out finite with increasing stamps.
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

#include "host_sim/recording/recording_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace v2xloc::sim;
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  std::string error;
  if (data[0] % 2 == 0) {
    RecordingReader reader;
    if (!reader.parse_manifest(text, error)) {
      if (error.empty()) std::abort();
      return 0;
    }
    if (reader.frame_count() < 1 || reader.frame_count() > RecordingReader::kMaxFrames ||
        !(reader.frame_rate() > 0) || !std::isfinite(reader.time_origin_unix()) || reader.trust_list_path().empty())
      std::abort();
    (void)reader.latest_map_clouds(1e9);
    return 0;
  }
  std::istringstream in(text);
  std::vector<TimedPose> poses;
  if (!parse_tum(in, "fuzz", poses, error)) {
    if (error.empty()) std::abort();
    return 0;
  }
  for (std::size_t i = 0; i < poses.size(); ++i)
    if (!std::isfinite(poses[i].t) || !poses[i].pose.matrix().allFinite() || (i > 0 && !(poses[i].t > poses[i - 1].t)))
      std::abort();
  return 0;
}
