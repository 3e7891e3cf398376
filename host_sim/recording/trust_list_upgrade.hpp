// Adds the infrastructure surveys to a recording's trust list (v2xloc-sim upgrade-trust).
// Recordings written before trust lists carried surveys still replay (the firmware then trusts
// an infrastructure unit on the pose it declares, and says so); this gives them the survey from
// the manifest's sensors[].surveyed_pose_enu, so the firmware refuses a unit declaring another pose.
#pragma once

#include <cstddef>
#include <string>

namespace v2xloc::sim {

struct TrustListUpgrade {
  bool already_surveyed = false;  // nothing to do: every infrastructure signer has its survey
  std::string file;               // the trust list the manifest names now (relative to the recording)
  std::size_t signers = 0;
  std::size_t surveyed = 0;
};

// The original list is kept (or, for a recording without one, the list derived from its sensors
// is the base): the surveyed list is written beside it (trust_list_surveyed.txt), then the
// manifest, replaced in one rename, names it (files.trust_list), so an interrupted upgrade leaves
// a recording that reads as before. Every infrastructure sensor of the manifest must have a
// signer in the list (the simulator's sender ids), else it is an error.
bool upgrade_trust_list(const std::string& dir, TrustListUpgrade& result, std::string& error);

}  // namespace v2xloc::sim
