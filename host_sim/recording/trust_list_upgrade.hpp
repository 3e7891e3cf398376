// Adds the infrastructure surveys, and their surveyed backgrounds, to a recording's trust list
// (v2xloc-sim upgrade-trust). Recordings written before trust lists carried them still replay (the
// firmware then trusts an infrastructure unit on the pose it declares, and on points it cannot
// check without a quorum, and says so); this gives them the survey from the manifest's
// sensors[].surveyed_pose_enu and a background rendered in the recording's world (seed) from that
// pose (sim_background.hpp), so the firmware refuses a unit declaring another pose or sending
// points off its scene.
#pragma once

#include <cstddef>
#include <string>

namespace v2xloc::sim {

struct TrustListUpgrade {
  bool already_surveyed = false;  // nothing to do: every infrastructure signer has what was asked for
  std::string file;               // the trust list the manifest names now (relative to the recording)
  std::size_t signers = 0;
  std::size_t surveyed = 0;
  std::size_t backgrounds = 0;
};

// The original list is kept (or, for a recording without one, the list derived from its sensors
// is the base): the upgraded list is written beside it (trust_list_surveyed.txt, or with
// backgrounds trust_list_background.txt and one background_<sensor>.bin per unit), then the
// manifest, replaced in one rename, names it (files.trust_list), so an interrupted upgrade leaves
// a recording that reads as before. Every infrastructure sensor of the manifest must have a
// signer in the list (the simulator's sender ids), else it is an error.
bool upgrade_trust_list(const std::string& dir, bool backgrounds, TrustListUpgrade& result, std::string& error);

}  // namespace v2xloc::sim
