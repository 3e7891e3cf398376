#include "host_sim/recording/can_log_upgrade.hpp"

#include <filesystem>
#include <vector>

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/manifest_rewrite.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

// gnss_vehicle.log -> gnss_vehicle_layout2.log (same folder inside the recording).
std::string converted_name(const std::string& original) {
  const fs::path p(original);
  const std::string name = p.stem().string() + "_layout" + std::to_string(kCanLayoutVersion) + p.extension().string();
  return (p.parent_path() / name).generic_string();
}

bool write_log(const std::string& path, const std::vector<CandumpRecord>& records, std::string& error) {
  std::string text;
  text.reserve(records.size() * 40);
  for (const CandumpRecord& r : records) text += format_candump_line(r) + "\n";
  return write_text_file(path, text, error);
}

// The manifest names the converted log.
bool name_converted_log(const std::string& dir, const std::string& original, const CanLogUpgrade& result,
                        std::string& error) {
  return rewrite_manifest(dir, [&](Json& m) {
    m["files"]["can_log"] = result.log_file;
    Json& can = m["can_log"];
    if (!can.is_object()) can = Json::object();
    can["file"] = result.log_file;
    can["frames"] = result.frames;
    can["gnss"] = kCanLayoutGnssFrames;
    can["layout_version"] = kCanLayoutVersion;
    can["converted_from"] = original;
  }, error);
}

}  // namespace

bool upgrade_can_log(const std::string& dir, CanLogUpgrade& result, std::string& error) {
  result = CanLogUpgrade{};
  RecordingReader reader;
  if (!reader.open(dir, error)) return false;
  const std::string log = reader.can_log_path();
  if (log.empty()) {
    error = dir + ": the recording has no CAN log";
    return false;
  }
  const std::string original = log.substr(dir.size() + 1);  // can_log_path() is dir + "/" + files.can_log
  if (reader.can_layout_version() == kCanLayoutVersion) {
    result.already_current = true;
    result.log_file = original;
    return true;
  }
  std::vector<CandumpRecord> records;  // converted as they are read
  if (!reader.can_records(records, error, &result.conversion)) return false;
  result.log_file = converted_name(original);
  result.frames = records.size();
  return write_log(dir + "/" + result.log_file, records, error) && name_converted_log(dir, original, result, error);
}

}  // namespace v2xloc::sim
