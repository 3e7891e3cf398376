// Which infrastructure units are fused: a quorum over their pairwise consistency verdicts.
// Every stored unit's latest cloud is checked against every other stored unit's where they
// overlap (map_consistency.hpp); the verdicts are kept per pair and direction (a dispute from
// either side is a dispute), and a unit is fused when more units vouch for it than dispute it.
// Rules, and why:
//   - a unit alone in the session (no other unit stored) is fused: nothing can check it yet; it
//     is surveyed and its share was signed, and a single-unit site would otherwise never have a
//     map. It is arbitrated again as soon as a second unit arrives;
//   - once other units are stored, a unit nobody can check (no overlap, e.g. shifted 200 m) is
//     held back: it is not corroborated, and it is not vouched for by being alone;
//   - a disagreement (or a lost overlap) is blamed on the unit whose new cloud broke an agreement
//     (the other unit's stored cloud agreed with its previous one, so it is the one that
//     changed): it counts against that unit and for the other. This arbitrates a pair: of two
//     units that agreed, the one that turns inconsistent mid-session is dropped, the other stays;
//   - two units that disagree from their first comparison cannot be arbitrated (nothing says
//     which is shifted): both are held back until a third unit, or a later agreement, decides.
#pragma once

#include <cstddef>
#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/localization/map_consistency.hpp"

namespace v2xloc {

struct QuorumStanding {
  std::uint32_t others = 0;     // other stored units
  std::uint32_t agree = 0;      // pairs that agree
  std::uint32_t upheld = 0;     // broken agreements blamed on the other unit
  std::uint32_t disagree = 0;   // disagreements blamed on nobody, broken agreements blamed on this unit
  bool fused() const { return others == 0 || agree + upheld > disagree; }
};

class InfraQuorum {
 public:
  static constexpr std::size_t kSlots = config::kMaxMapSources;

  void clear();
  // The slot now holds another source (or none): its verdicts no longer apply.
  void forget(std::size_t slot);
  // `slot`'s new cloud was checked against the cloud stored in `other`.
  void record(std::size_t slot, std::size_t other, MapCheckVerdict verdict);
  // Standing of `slot` among the slots with stored[s] set.
  QuorumStanding standing(std::size_t slot, const bool (&stored)[kSlots]) const;
  // Both directions joined: a dispute if either disputes, else an agreement if either agrees.
  MapCheckVerdict verdict(std::size_t a, std::size_t b) const;

 private:
  static constexpr std::uint8_t kNobody = 0xff;
  struct Pair {  // one direction: the first slot's planes against the second's points
    MapCheckVerdict verdict = MapCheckVerdict::kUncheckable;
    bool known = false;  // checked since both slots were assigned
  };
  Pair pairs_[kSlots][kSlots];
  std::uint8_t blamed_[kSlots][kSlots] = {};  // symmetric: slot whose new cloud broke an agreement
};

}  // namespace v2xloc
