// Fault injection on the replay path (v2xloc-replay --faults SPEC, v2xloc-eval --faults SPEC):
// the canonical event stream is altered before it reaches the firmware (over emulated CAN/UDP) or
// the offline decoder, deterministically (seeded). SPEC is comma-separated key=value:
//   seed=N             PRNG seed (default 1)
//   loss=P             each V2X map share is lost with probability P (one random fragment of it
//                      is dropped, so the firmware's reassembly times the share out)
//   frag-loss=P        each V2X datagram dropped with probability P
//   reorder=P          each V2X datagram swapped with the next one with probability P
//   dup=P              each V2X datagram sent twice with probability P
//   delay=S            V2X shares delivered S seconds after their stamp
//   gnss-outage=S      GNSS CAN frames (0x130..0x134) dropped for S seconds from gnss-outage-at
//   gnss-outage-at=S   start of the outage, recording time (default 1.0)
//   infra-dropout=S    every infrastructure unit silent for S seconds from infra-dropout-at
//   infra-dropout-at=S (default 1.0)
//   can-burst=N        N corrupt frames (bad CRC, repeated counters, wrong DLC) on the GNSS/vehicle
//                      ids at can-burst-at (default 1.0 s)
//   rogue-shift=M      a rogue source: rogue-source's clouds shifted M metres east
//   rogue-source=NAME  infra_0 (default), agent_0_lidar, all-infra
//   rogue-signed=0|1   1 (default): the source itself sends the shifted clouds, signed with its
//                      provisioned key (a compromised / mis-surveyed insider). 0: an outsider
//                      injects shifted copies under the source's sender id, unsigned, beside the
//                      genuine clouds.
//   rogue-points=0|1   1: the shift moves the points and the share declares the true (surveyed)
//                      pose; 0 (default): the declared pose is shifted, the points are as sensed
//   rogue-future=S     an outsider injects a copy of rogue-source's clouds dated S seconds ahead
//                      (signed with rogue-signed=1: by a key not in the trust list)
//   rogue-ids=N        an outsider floods N invented agent sender ids (unsigned) every share period
//   ego-time-jump=F    ego scan F is stamped 1e18 ns (year 2001 + 31 years of ns: far future)
//   lidar-blind=S      the ego LiDAR blind for S seconds from lidar-blind-at: the scans stamped in
//                      the spell never reach the firmware (no registration, no odometry)
//   lidar-blind-at=S   start of the spell, recording time (default 1.0)
//   lidar-blind-empty=0|1  1: the LiDAR still sends its scans in the spell, with no points (a
//                      covered sensor); 0 (default): it sends nothing (a silent sensor)
//   imu-*              IMU dropout, stuck axis, bias step, repeated and reordered reports
//                      (host_sim/replay/imu_faults.hpp)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host_sim/common/rng.hpp"
#include "host_sim/replay/imu_faults.hpp"

namespace v2xloc::sim::replay {

struct FaultSpec {
  std::uint64_t seed = 1;
  double loss = 0.0, frag_loss = 0.0, reorder = 0.0, duplicate = 0.0;
  double delay_s = 0.0;
  double gnss_outage_s = 0.0, gnss_outage_at_s = 1.0;
  double infra_dropout_s = 0.0, infra_dropout_at_s = 1.0;
  int can_burst = 0;
  double can_burst_at_s = 1.0;
  double rogue_shift_m = 0.0;
  std::string rogue_source = "infra_0";
  bool rogue_signed = true;
  bool rogue_points = false;  // shift the points, declare the true pose (what a survey cannot catch)
  double rogue_future_s = 0.0;
  int rogue_ids = 0;
  int ego_time_jump_frame = -1;
  double lidar_blind_s = 0.0, lidar_blind_at_s = 1.0;
  bool lidar_blind_empty = false;
  ImuFaultSpec imu{};
  bool any() const;
};

// False + error for unknown keys or bad values.
bool parse_fault_spec(const std::string& spec, FaultSpec& out, std::string& error);
std::string describe(const FaultSpec& spec);

// What the injector did (every dropped or altered input is counted here; the firmware counts
// what it rejected).
struct FaultStats {
  std::uint64_t shares_lost = 0, datagrams_dropped = 0, datagrams_reordered = 0, datagrams_duplicated = 0;
  std::uint64_t shares_delayed = 0, gnss_frames_dropped = 0, infra_shares_dropped = 0, can_corrupt_sent = 0;
  std::uint64_t rogue_shares = 0, ego_time_jumps = 0;
  std::uint64_t ego_scans_blinded = 0;  // ego scans withheld (or sent empty) by lidar-blind
  ImuFaultStats imu{};
};

class FaultInjector {
 public:
  void configure(const FaultSpec& spec) {
    spec_ = spec;
    rng_ = Rng(spec.seed * 0x9E3779B97F4A7C15ull + 17);
  }
  const FaultSpec& spec() const { return spec_; }
  // Loss / fragment loss / reorder / duplication on one V2X share's datagrams (index 0 may be
  // the signature datagram; it is subject to the same faults).
  void transport(std::vector<std::vector<std::uint8_t>>& datagrams, FaultStats& stats);
  bool gnss_dropped(std::uint32_t can_id, double t_s) const;
  bool infra_dropped(double t_s) const;
  // True for an ego scan stamped t_s inside the lidar-blind spell.
  bool lidar_blinded(double t_s) const;
  Rng& rng() { return rng_; }

 private:
  FaultSpec spec_{};
  Rng rng_{1};
};

}  // namespace v2xloc::sim::replay
