#include "host_sim/recording/manifest_rewrite.hpp"

#include <filesystem>

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/recording_reader.hpp"

namespace v2xloc::sim {

bool rewrite_manifest(const std::string& dir, const std::function<void(Json&)>& edit, std::string& error) {
  const std::string path = dir + "/manifest.json";
  std::string text;
  if (!read_text_file(path, kMaxManifestBytes, text, error)) return false;
  Json m = Json::parse(text, nullptr, false);
  if (m.is_discarded() || !m.is_object() || !m.contains("files") || !m["files"].is_object()) {
    error = path + ": not the manifest the reader accepted";
    return false;
  }
  edit(m);
  const std::string tmp = path + ".tmp";
  if (!write_text_file(tmp, m.dump(2) + "\n", error)) return false;
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) error = "cannot replace " + path + ": " + ec.message();
  return !ec;
}

}  // namespace v2xloc::sim
