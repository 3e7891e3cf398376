#include "v2xloc/algo/correspondences.hpp"

namespace v2xloc {

CorrespondenceResult match_features(std::span<const Feature33> source_features,
                                    const KdTree<Feature33>& target_tree,
                                    const CorrespondenceParams& params,
                                    BoundedVector<Correspondence>& out,
                                    const KdTree<Feature33>* source_tree,
                                    std::span<std::uint32_t> scratch) {
  CorrespondenceResult r;
  out.clear();
  if (source_features.empty() || target_tree.empty()) {
    r.status = CorrespondenceStatus::kEmptyInput;
    return r;
  }
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  const std::size_t num_target = target_tree.points().size();
  if (params.mutual_filter &&
      (source_tree == nullptr || source_tree->empty() || scratch.size() < num_target)) {
    r.status = CorrespondenceStatus::kInvalidStorage;
    return r;
  }

  // Source -> target, in source order.
  for (std::size_t i = 0; i < source_features.size(); ++i) {
    Neighbor nn{};
    const KdQueryResult kr = target_tree.nearest(source_features[i], nn);
    r.search.add(kr);
    if (kr.count == 0) {
      ++r.no_match;
      continue;
    }
    if (!out.push_back({static_cast<std::uint32_t>(i), nn.index})) ++r.truncated;
  }

  if (params.mutual_filter) {
    // Target -> source for every target feature.
    const std::span<const Feature33> targets = target_tree.points();
    for (std::size_t j = 0; j < num_target; ++j) {
      Neighbor nn{};
      const KdQueryResult kr = source_tree->nearest(targets[j], nn);
      r.search.add(kr);
      scratch[j] = kr.count == 0 ? kNone : nn.index;
    }
    std::size_t mutual = 0;
    for (const Correspondence& c : out) {
      if (scratch[c.target] == c.source) ++mutual;
    }
    if (mutual >= params.min_mutual) {
      std::size_t w = 0;
      for (std::size_t k = 0; k < out.size(); ++k) {
        if (scratch[out[k].target] == out[k].source) out[w++] = out[k];
      }
      r.mutual_rejected = static_cast<std::uint32_t>(out.size() - w);
      out.resize(w);
    } else {
      r.fell_back = true;
    }
  }
  r.count = static_cast<std::uint32_t>(out.size());
  r.status = r.count > 0 ? CorrespondenceStatus::kOk : CorrespondenceStatus::kNoMatches;
  return r;
}

}  // namespace v2xloc
