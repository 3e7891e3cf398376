#include "host_sim/recording/trust_list_upgrade.hpp"

#include <filesystem>

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_trust.hpp"

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxManifestBytes = 64u << 20;  // as the reader's cap
constexpr const char* kSurveyedFile = "trust_list_surveyed.txt";

// The base list: the recording's file, else derived from its map-cloud sensors (as the replay does).
bool base_list(const RecordingReader& reader, trust::TrustList& list, std::string& error) {
  if (!reader.trust_list_path().empty()) return load_trust_list(reader.trust_list_path(), list, error);
  std::vector<SimSigner> signers;
  for (const MapCloudInfo& c : reader.map_clouds()) {
    bool known = false;
    for (const SimSigner& s : signers) known = known || s.sensor == c.sensor;
    SimSigner signer;
    if (!known && sim_signer(c.kind, c.sensor, signer)) signers.push_back(signer);
  }
  list = trust_list_of(signers);
  return true;
}

bool name_in_manifest(const std::string& dir, const std::string& file, std::string& error) {
  const std::string path = dir + "/manifest.json";
  std::string text;
  if (!read_text_file(path, kMaxManifestBytes, text, error)) return false;
  Json m = Json::parse(text, nullptr, false);
  if (m.is_discarded() || !m.is_object() || !m.contains("files") || !m["files"].is_object()) {
    error = path + ": not the manifest the reader accepted";
    return false;
  }
  m["files"]["trust_list"] = file;
  const std::string tmp = path + ".tmp";
  if (!write_text_file(tmp, m.dump(2) + "\n", error)) return false;
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) error = "cannot replace " + path + ": " + ec.message();
  return !ec;
}

}  // namespace

bool upgrade_trust_list(const std::string& dir, TrustListUpgrade& result, std::string& error) {
  result = TrustListUpgrade{};
  RecordingReader reader;
  if (!reader.open(dir, error)) return false;
  trust::TrustList list;
  if (!base_list(reader, list, error)) return false;
  const auto& names = reader.infra_sensor_names();
  const auto& poses = reader.infra_surveyed_poses();
  bool changed = false;
  for (std::size_t k = 0; k < names.size() && k < poses.size(); ++k) {
    std::uint32_t id = 0;
    trust::TrustedSigner* signer = nullptr;
    if (sim_sender_id("infra", names[k], id)) {
      for (std::size_t i = 0; i < list.count; ++i) {
        if (list.signers[i].sender_id == id && list.signers[i].role == trust::SignerRole::kInfrastructure) {
          signer = &list.signers[i];
        }
      }
    }
    if (signer == nullptr) {
      error = dir + ": infrastructure sensor " + names[k] + " has no infrastructure signer on the trust list";
      return false;
    }
    const trust::SurveyedPose survey = surveyed_pose(poses[k]);
    changed = changed || !signer->surveyed;
    signer->surveyed = true;
    signer->survey = survey;
  }
  result.signers = list.count;
  result.surveyed = list.surveyed_count();
  const std::string current = reader.trust_list_path();
  if (!changed && !current.empty()) {
    result.already_surveyed = true;
    result.file = current.substr(dir.size() + 1);  // trust_list_path() is dir + "/" + files.trust_list
    return true;
  }
  result.file = kSurveyedFile;
  return write_text_file(dir + "/" + result.file, trust_list_text(list), error) &&
         name_in_manifest(dir, result.file, error);
}

}  // namespace v2xloc::sim
