#include "host_sim/replay/fault_injection.hpp"

#include "firmware/protocol/can_messages.hpp"

#include <cstdlib>
#include <sstream>
#include <utility>

namespace v2xloc::sim::replay {
bool FaultSpec::any() const {
  return loss > 0 || frag_loss > 0 || reorder > 0 || duplicate > 0 || delay_s > 0 || gnss_outage_s > 0 ||
         infra_dropout_s > 0 || can_burst > 0 || rogue_shift_m != 0 || rogue_future_s != 0 || rogue_ids > 0 ||
         ego_time_jump_frame >= 0 || lidar_blind_s > 0 || imu.any();
}

bool parse_fault_spec(const std::string& spec, FaultSpec& out, std::string& error) {
  FaultSpec f;
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const std::string value = eq == std::string::npos ? "" : item.substr(eq + 1);
    double d = 0;
    bool ok = true;
    const auto prob = [&](double& field) { ok = parse_fault_number(value, 0.0, 1.0, field); };
    const auto secs = [&](double& field) { ok = parse_fault_number(value, 0.0, 1e6, field); };
    if (key == "none" && eq == std::string::npos) {
      // no fault (a baseline run that still reports the counts)
    } else if (key == "seed") {
      ok = parse_fault_number(value, 0, 1e15, d);
      f.seed = static_cast<std::uint64_t>(d);
    } else if (key == "loss") prob(f.loss);
    else if (key == "frag-loss") prob(f.frag_loss);
    else if (key == "reorder") prob(f.reorder);
    else if (key == "dup") prob(f.duplicate);
    else if (key == "delay") secs(f.delay_s);
    else if (key == "gnss-outage") secs(f.gnss_outage_s);
    else if (key == "gnss-outage-at") secs(f.gnss_outage_at_s);
    else if (key == "infra-dropout") secs(f.infra_dropout_s);
    else if (key == "infra-dropout-at") secs(f.infra_dropout_at_s);
    else if (key == "can-burst") {
      ok = parse_fault_number(value, 0, 100000, d);
      f.can_burst = static_cast<int>(d);
    } else if (key == "can-burst-at") secs(f.can_burst_at_s);
    else if (key == "rogue-shift") ok = parse_fault_number(value, -1e5, 1e5, f.rogue_shift_m);
    else if (key == "rogue-source") {
      f.rogue_source = value;
      ok = !value.empty();
    } else if (key == "rogue-signed") {
      ok = value == "0" || value == "1";
      f.rogue_signed = value == "1";
    } else if (key == "rogue-points") {
      ok = value == "0" || value == "1";
      f.rogue_points = value == "1";
    } else if (key == "rogue-future") secs(f.rogue_future_s);
    else if (key == "rogue-ids") {
      ok = parse_fault_number(value, 0, 1000, d);
      f.rogue_ids = static_cast<int>(d);
    } else if (key == "ego-time-jump") {
      ok = parse_fault_number(value, 0, 1e9, d);
      f.ego_time_jump_frame = static_cast<int>(d);
    } else if (key == "lidar-blind") secs(f.lidar_blind_s);
    else if (key == "lidar-blind-at") secs(f.lidar_blind_at_s);
    else if (key == "lidar-blind-empty") {
      ok = value == "0" || value == "1";
      f.lidar_blind_empty = value == "1";
    } else if (!parse_imu_fault(key, value, f.imu, ok)) {
      error = "unknown fault '" + key + "'";
      return false;
    }
    if (!ok) {
      error = "bad value for fault '" + key + "': '" + value + "'";
      return false;
    }
  }
  out = f;
  return true;
}

std::string describe(const FaultSpec& f) {
  std::ostringstream o;
  if (f.loss > 0) o << " loss=" << f.loss;
  if (f.frag_loss > 0) o << " frag-loss=" << f.frag_loss;
  if (f.reorder > 0) o << " reorder=" << f.reorder;
  if (f.duplicate > 0) o << " dup=" << f.duplicate;
  if (f.delay_s > 0) o << " delay=" << f.delay_s;
  if (f.gnss_outage_s > 0) o << " gnss-outage=" << f.gnss_outage_s << "@" << f.gnss_outage_at_s;
  if (f.infra_dropout_s > 0) o << " infra-dropout=" << f.infra_dropout_s << "@" << f.infra_dropout_at_s;
  if (f.can_burst > 0) o << " can-burst=" << f.can_burst << "@" << f.can_burst_at_s;
  if (f.rogue_shift_m != 0) o << " rogue-shift=" << f.rogue_shift_m << "(" << f.rogue_source << (f.rogue_signed ? ",signed" : ",unsigned")
                              << (f.rogue_points ? ",points)" : ")");
  if (f.rogue_future_s > 0) o << " rogue-future=" << f.rogue_future_s;
  if (f.rogue_ids > 0) o << " rogue-ids=" << f.rogue_ids;
  if (f.ego_time_jump_frame >= 0) o << " ego-time-jump=" << f.ego_time_jump_frame;
  if (f.lidar_blind_s > 0) o << " lidar-blind=" << f.lidar_blind_s << "@" << f.lidar_blind_at_s
                              << (f.lidar_blind_empty ? "(empty scans)" : "(no scans)");
  o << describe(f.imu);
  const std::string s = o.str();
  return s.empty() ? "none" : s.substr(1);
}

void FaultInjector::transport(std::vector<std::vector<std::uint8_t>>& d, FaultStats& stats) {
  if (spec_.loss > 0 && !d.empty() && rng_.bernoulli(spec_.loss)) {
    d.erase(d.begin() + rng_.uniform_int(0, static_cast<int>(d.size()) - 1));
    ++stats.shares_lost;
    ++stats.datagrams_dropped;
  }
  if (spec_.frag_loss > 0) {
    std::vector<std::vector<std::uint8_t>> kept;
    for (auto& x : d) {
      if (rng_.bernoulli(spec_.frag_loss)) {
        ++stats.datagrams_dropped;
      } else {
        kept.push_back(std::move(x));
      }
    }
    d.swap(kept);
  }
  if (spec_.duplicate > 0) {
    std::vector<std::vector<std::uint8_t>> out;
    for (auto& x : d) {
      out.push_back(x);
      if (rng_.bernoulli(spec_.duplicate)) {
        out.push_back(x);
        ++stats.datagrams_duplicated;
      }
    }
    d.swap(out);
  }
  if (spec_.reorder > 0) {
    for (std::size_t i = 0; i + 1 < d.size(); ++i) {
      if (rng_.bernoulli(spec_.reorder)) {
        std::swap(d[i], d[i + 1]);
        ++stats.datagrams_reordered;
        ++i;
      }
    }
  }
}

bool FaultInjector::gnss_dropped(std::uint32_t id, double t) const {
  // Every GNSS frame of a fix: 0x130 (latitude, longitude), 0x131, 0x132, 0x133, 0x134.
  const bool gnss = id >= protocol::kGnssPositionId && id <= protocol::kGnssDopId;
  return spec_.gnss_outage_s > 0 && gnss && t >= spec_.gnss_outage_at_s &&
         t < spec_.gnss_outage_at_s + spec_.gnss_outage_s;
}

bool FaultInjector::infra_dropped(double t) const {
  return spec_.infra_dropout_s > 0 && t >= spec_.infra_dropout_at_s && t < spec_.infra_dropout_at_s + spec_.infra_dropout_s;
}

bool FaultInjector::lidar_blinded(double t) const {
  return spec_.lidar_blind_s > 0 && t >= spec_.lidar_blind_at_s && t < spec_.lidar_blind_at_s + spec_.lidar_blind_s;
}

}  // namespace v2xloc::sim::replay
