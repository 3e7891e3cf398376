#include "host_sim/recording/trust_list_upgrade.hpp"

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/manifest_rewrite.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_trust.hpp"

namespace v2xloc::sim {
namespace {

constexpr const char* kSurveyedFile = "trust_list_surveyed.txt";

}  // namespace

bool upgrade_trust_list(const std::string& dir, TrustListUpgrade& result, std::string& error) {
  result = TrustListUpgrade{};
  RecordingReader reader;
  if (!reader.open(dir, error)) return false;
  trust::TrustList list;
  if (!recording_trust_list(reader, recording_signers(reader), list, error)) return false;
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
         rewrite_manifest(dir, [&](Json& m) { m["files"]["trust_list"] = result.file; }, error);
}

}  // namespace v2xloc::sim
