#include "v2xloc/algo/localization/map_quorum.hpp"

namespace v2xloc {

void InfraQuorum::clear() {
  for (std::size_t a = 0; a < kSlots; ++a) {
    for (std::size_t b = 0; b < kSlots; ++b) {
      pairs_[a][b] = Pair{};
      blamed_[a][b] = kNobody;
    }
  }
}

void InfraQuorum::forget(std::size_t slot) {
  if (slot >= kSlots) return;
  for (std::size_t s = 0; s < kSlots; ++s) {
    pairs_[slot][s] = Pair{};
    pairs_[s][slot] = Pair{};
    blamed_[slot][s] = kNobody;
    blamed_[s][slot] = kNobody;
  }
}

// The pair's verdict joins both directions' latest checks (each unit's planes against the other's
// points): one dispute is a dispute (a shift seen from one side only, e.g. a wall the other unit
// slides along), one agreement with an uncheckable other side is an agreement.
MapCheckVerdict InfraQuorum::verdict(std::size_t a, std::size_t b) const {
  const Pair& ab = pairs_[a][b];
  const Pair& ba = pairs_[b][a];
  if (ab.verdict == MapCheckVerdict::kDisagree || ba.verdict == MapCheckVerdict::kDisagree)
    return MapCheckVerdict::kDisagree;
  if (ab.verdict == MapCheckVerdict::kAgree || ba.verdict == MapCheckVerdict::kAgree) return MapCheckVerdict::kAgree;
  return MapCheckVerdict::kUncheckable;
}

void InfraQuorum::record(std::size_t slot, std::size_t other, MapCheckVerdict verdict) {
  if (slot >= kSlots || other >= kSlots || slot == other) return;
  const bool was_known = pairs_[slot][other].known || pairs_[other][slot].known;
  const MapCheckVerdict before = this->verdict(slot, other);
  pairs_[slot][other].verdict = verdict;
  pairs_[slot][other].known = true;
  const MapCheckVerdict after = this->verdict(slot, other);
  // A verdict other than agreement that breaks an agreement blames this slot (its cloud changed,
  // the other's stored cloud did not); a standing dispute keeps its blame; agreement clears it.
  std::uint8_t blamed = blamed_[slot][other];
  if (after == MapCheckVerdict::kAgree || !was_known) blamed = kNobody;
  else if (before == MapCheckVerdict::kAgree) blamed = static_cast<std::uint8_t>(slot);
  blamed_[slot][other] = blamed;
  blamed_[other][slot] = blamed;
}

QuorumStanding InfraQuorum::standing(std::size_t slot, const bool (&stored)[kSlots]) const {
  QuorumStanding q;
  for (std::size_t s = 0; s < kSlots; ++s) {
    if (s == slot || !stored[s]) continue;
    ++q.others;
    if (!pairs_[slot][s].known && !pairs_[s][slot].known) continue;
    const MapCheckVerdict v = verdict(slot, s);
    if (v == MapCheckVerdict::kAgree) ++q.agree;
    else if (blamed_[slot][s] == s) ++q.upheld;
    else if (blamed_[slot][s] == slot || v == MapCheckVerdict::kDisagree) ++q.disagree;
  }
  return q;
}

}  // namespace v2xloc
