// Deterministic test keys and the trust list of a simulated recording. Every map-cloud sensor of
// the simulator ("infra_2", "agent_1_lidar") signs its V2X shares with a P-256 key derived from
// its name (trust::private_key_from_seed over "v2xloc-sim test key/" + name): the same keys in
// every run and every recording, so recordings stay byte-identical and tests can re-derive them.
// These are TEST keys, public by construction; a deployment provisions real ones.
// The recording carries the public half as trust_list.txt (manifest files.trust_list).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "firmware/trust/trust_list.hpp"
#include "host_sim/recording/recording_reader.hpp"

namespace v2xloc::sim {

inline constexpr const char* kTrustListFile = "trust_list.txt";

struct SimSigner {
  std::string sensor;  // recording sensor name
  std::uint32_t sender_id = 0;
  trust::SignerRole role = trust::SignerRole::kAgent;
  trust::PrivateKey priv{};
  trust::PublicKey pub{};
  bool surveyed = false;  // infrastructure: its sensor pose goes on the trust list as a survey
  trust::SurveyedPose survey{};
};

// The trust list's form of a surveyed sensor pose (sensor -> ENU), as the share header declares it.
trust::SurveyedPose surveyed_pose(const Eigen::Isometry3d& sensor_to_enu);

// Sender id of a map-cloud sensor: "infra_k" -> 1 + k (k < 31), "agent_k..." -> 32 + k.
bool sim_sender_id(const std::string& kind, const std::string& sensor, std::uint32_t& sender_id);
// The signer of sensor `sensor` (kind "infra" | "agent"); false for an unknown name.
bool sim_signer(const std::string& kind, const std::string& sensor, SimSigner& out);
// A signer whose key no trust list names (the rogue of the fault injection).
SimSigner sim_unlisted_signer(std::uint32_t sender_id);
trust::TrustList trust_list_of(const std::vector<SimSigner>& signers);
// One signer per map-cloud sensor of a recording, in order of first appearance (unknown names skipped).
std::vector<SimSigner> recording_signers(const RecordingReader& reader);
// The recording's provisioned list: its trust-list file, or (recordings made before the file) the
// list of its map-cloud sensors' signers.
bool recording_trust_list(const RecordingReader& reader, const std::vector<SimSigner>& signers,
                          trust::TrustList& out, std::string& error);
std::string trust_list_text(const trust::TrustList& list);
// Reads and parses a trust-list file; false + error (with line) on failure.
bool load_trust_list(const std::string& path, trust::TrustList& out, std::string& error);

}  // namespace v2xloc::sim
