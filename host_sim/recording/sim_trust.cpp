#include "host_sim/recording/sim_trust.hpp"

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace v2xloc::sim {
namespace {

bool index_after(const std::string& name, const std::string& prefix, std::uint32_t& index) {
  if (name.rfind(prefix, 0) != 0 || name.size() == prefix.size()) return false;
  const char* begin = name.c_str() + prefix.size();
  char* end = nullptr;
  const unsigned long v = std::strtoul(begin, &end, 10);
  if (end == begin || v > 0xFFFFu) return false;
  index = static_cast<std::uint32_t>(v);
  return true;
}

trust::PrivateKey key_for(const std::string& label) {
  const std::string seed = "v2xloc-sim test key/" + label;
  return trust::private_key_from_seed(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(seed.data()), seed.size()));
}

}  // namespace

bool sim_sender_id(const std::string& kind, const std::string& sensor, std::uint32_t& sender_id) {
  std::uint32_t k = 0;
  if (kind == "infra" && index_after(sensor, "infra_", k) && k < 31) {
    sender_id = 1 + k;
    return true;
  }
  if (kind == "agent" && index_after(sensor, "agent_", k)) {
    sender_id = 32 + k;
    return true;
  }
  return false;
}

trust::SurveyedPose surveyed_pose(const Eigen::Isometry3d& sensor_to_enu) {
  trust::SurveyedPose p;
  const Eigen::Quaterniond q(sensor_to_enu.linear());
  for (int k = 0; k < 3; ++k) p.position_m[static_cast<std::size_t>(k)] = sensor_to_enu.translation()[k];
  p.quaternion_xyzw = {q.x(), q.y(), q.z(), q.w()};
  return p;
}

bool sim_signer(const std::string& kind, const std::string& sensor, SimSigner& out) {
  SimSigner s;
  if (!sim_sender_id(kind, sensor, s.sender_id)) return false;
  s.sensor = sensor;
  s.role = kind == "infra" ? trust::SignerRole::kInfrastructure : trust::SignerRole::kAgent;
  s.priv = key_for(sensor);
  if (trust::derive_public_key(s.priv, s.pub) != trust::CryptoStatus::kOk) return false;
  out = s;
  return true;
}

std::vector<SimSigner> recording_signers(const RecordingReader& reader) {
  std::vector<SimSigner> signers;
  for (const MapCloudInfo& c : reader.map_clouds()) {
    bool known = false;
    for (const SimSigner& s : signers) known = known || s.sensor == c.sensor;
    SimSigner signer;
    if (!known && sim_signer(c.kind, c.sensor, signer)) signers.push_back(signer);
  }
  return signers;
}

bool recording_trust_list(const RecordingReader& reader, const std::vector<SimSigner>& signers,
                          trust::TrustList& out, std::string& error) {
  if (!reader.trust_list_path().empty()) return load_trust_list(reader.trust_list_path(), out, error);
  out = trust_list_of(signers);
  return true;
}

SimSigner sim_unlisted_signer(std::uint32_t sender_id) {
  SimSigner s;
  s.sensor = "rogue_" + std::to_string(sender_id);
  s.sender_id = sender_id;
  s.priv = key_for(s.sensor);
  trust::derive_public_key(s.priv, s.pub);
  return s;
}

trust::TrustList trust_list_of(const std::vector<SimSigner>& signers) {
  trust::TrustList list;
  for (const SimSigner& s : signers) {
    if (list.count == trust::kMaxTrustedSigners) break;
    trust::TrustedSigner& t = list.signers[list.count++];
    t.key = s.pub;
    t.id = trust::hashed_id8(s.pub);
    t.role = s.role;
    t.sender_id = s.sender_id;
    const std::size_t n = std::min(s.sensor.size(), t.name.size() - 1);
    s.sensor.copy(t.name.data(), n);
    t.surveyed = s.surveyed && s.role == trust::SignerRole::kInfrastructure;
    t.survey = s.survey;
  }
  return list;
}

std::string trust_list_text(const trust::TrustList& list) {
  // The file's bound: kMaxTrustedSigners entries with survey and background lines take ~17 kB.
  std::string buf(trust::kMaxTrustListBytes, '\0');
  buf.resize(trust::format_trust_list(list, buf));
  return buf;
}

bool load_trust_list(const std::string& path, trust::TrustList& out, std::string& error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    error = "cannot read " + path;
    return false;
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  const trust::TrustListParseResult r = trust::parse_trust_list(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), out);
  if (r.status != trust::TrustListStatus::kOk) {
    error = path + ":" + std::to_string(r.line) + ": " + trust::to_string(r.status);
    return false;
  }
  return true;
}

}  // namespace v2xloc::sim
