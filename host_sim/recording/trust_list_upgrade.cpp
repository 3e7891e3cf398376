#include "host_sim/recording/trust_list_upgrade.hpp"

#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/manifest_rewrite.hpp"
#include "host_sim/recording/pose_io.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_background.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/world/intersection_world.hpp"
#include "v2xloc/algo/core/config.hpp"

namespace v2xloc::sim {
namespace {

constexpr const char* kSurveyedFile = "trust_list_surveyed.txt";
constexpr const char* kBackgroundFile = "trust_list_background.txt";

// The infrastructure signer of sensor `name` on the list, else null.
trust::TrustedSigner* infrastructure_signer(trust::TrustList& list, const std::string& name) {
  std::uint32_t id = 0;
  if (!sim_sender_id("infra", name, id)) return nullptr;
  for (std::size_t i = 0; i < list.count; ++i) {
    if (list.signers[i].sender_id == id && list.signers[i].role == trust::SignerRole::kInfrastructure) {
      return &list.signers[i];
    }
  }
  return nullptr;
}

// Renders the backgrounds of the signers that have none (the recording's world from its seed,
// without vehicles, each unit from its surveyed pose), written into dir.
bool add_backgrounds(const RecordingReader& reader, const std::string& dir, trust::TrustList& list, std::string& error) {
  IntersectionWorld survey;
  WorldConfig world_config;
  world_config.seed = reader.seed();
  build_intersection_world(world_config, survey);
  const auto& names = reader.infra_sensor_names();
  for (std::size_t k = 0; k < names.size(); ++k) {
    trust::TrustedSigner* signer = infrastructure_signer(list, names[k]);
    if (signer == nullptr || signer->has_background) continue;
    LidarConfig cfg = infra_lidar_config(reader.quick());
    cfg.name = names[k];
    cfg.mount = Eigen::Isometry3d::Identity();
    SimBackground bg;
    if (!render_background(survey.world, cfg, reader.infra_surveyed_poses()[k], reader.seed(), k,
                           config::kBackgroundFileCells, bg, error) ||
        !write_background(dir, names[k], bg, *signer, error)) {
      return false;
    }
  }
  return true;
}

}  // namespace

bool upgrade_trust_list(const std::string& dir, bool backgrounds, TrustListUpgrade& result, std::string& error) {
  result = TrustListUpgrade{};
  RecordingReader reader;
  if (!reader.open(dir, error)) return false;
  trust::TrustList list;
  if (!recording_trust_list(reader, recording_signers(reader), list, error)) return false;
  const auto& names = reader.infra_sensor_names();
  const auto& poses = reader.infra_surveyed_poses();
  bool changed = false;
  for (std::size_t k = 0; k < names.size() && k < poses.size(); ++k) {
    trust::TrustedSigner* signer = infrastructure_signer(list, names[k]);
    if (signer == nullptr) {
      error = dir + ": infrastructure sensor " + names[k] + " has no infrastructure signer on the trust list";
      return false;
    }
    changed = changed || !signer->surveyed || (backgrounds && !signer->has_background);
    signer->surveyed = true;
    signer->survey = surveyed_pose(poses[k]);
  }
  const std::string current = reader.trust_list_path();
  if (!changed && !current.empty()) {
    result.already_surveyed = true;
    result.file = current.substr(dir.size() + 1);  // trust_list_path() is dir + "/" + files.trust_list
  } else {
    result.file = backgrounds ? kBackgroundFile : kSurveyedFile;
    if ((backgrounds && !add_backgrounds(reader, dir, list, error)) ||
        !write_text_file(dir + "/" + result.file, trust_list_text(list), error) ||
        !rewrite_manifest(dir, [&](Json& m) { m["files"]["trust_list"] = result.file; }, error)) {
      return false;
    }
  }
  result.signers = list.count;
  result.surveyed = list.surveyed_count();
  result.backgrounds = list.background_count();
  return true;
}

}  // namespace v2xloc::sim
