#include "v2xloc/algo/search/kdtree.hpp"

#include <algorithm>
#include <cmath>

#include "v2xloc/algo/core/finite.hpp"

namespace v2xloc {
namespace {

// Squared distance in float, serial sum (same bits everywhere with -ffp-contract=off). 3-D is
// spelled out: GCC -O2 kept the 3-step loop, a fifth of a nearest-neighbour query's instructions
// (callgrind); t0 * t0 is 0 + t0 * t0 exactly (a square is never -0), so the bits are the loop's.
template <int D>
inline float squared_distance(const float* a, const float* b) {
  if constexpr (D == 3) {
    const float t0 = a[0] - b[0], t1 = a[1] - b[1], t2 = a[2] - b[2];
    float s = t0 * t0;
    s += t1 * t1;
    s += t2 * t2;
    return s;
  } else {
    float s = 0.0f;
    for (int d = 0; d < D; ++d) {
      const float t = a[d] - b[d];
      s += t * t;
    }
    return s;
  }
}

// Same, but gives up once the partial sum exceeds `bound` (returns a value > bound). Pays off in
// high dimension where most leaf candidates are rejected early. Above 8 dimensions the sum runs
// in 8 independent lanes combined in a fixed tree: the order is part of the source, so the
// compiler may vectorise the lanes (SSE/NEON) without changing a bit on any ISA.
template <int D>
inline float squared_distance_bounded(const float* a, const float* b, float bound) {
  if constexpr (D <= 8) {
    return squared_distance<D>(a, b);
  } else {
    float lane[8] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    const auto combine = [&lane]() {
      return ((lane[0] + lane[1]) + (lane[2] + lane[3])) +
             ((lane[4] + lane[5]) + (lane[6] + lane[7]));
    };
    int d = 0;
    for (; d + 8 <= D; d += 8) {
      for (int j = 0; j < 8; ++j) {
        const float t = a[d + j] - b[d + j];
        lane[j] += t * t;
      }
      if (d == 8 && combine() > bound) return combine();  // check once, after 16 dims
    }
    float s = combine();
    for (; d < D; ++d) {
      const float t = a[d] - b[d];
      s += t * t;
    }
    return s;
  }
}

// Strict total order of neighbours: distance, then index (deterministic ties). Squared
// distances are >= +0 (sums of squares; never -0 or NaN for finite points), so the float compare
// and its tie are exact (the same order as comparing their bit patterns, fewer instructions). A
// function object, so the heap and sort algorithms inline it.
struct Closer {
  bool operator()(const Neighbor& a, const Neighbor& b) const {
    return a.squared_distance < b.squared_distance ||
           (a.squared_distance == b.squared_distance && a.index < b.index);
  }
};
inline bool closer(const Neighbor& a, const Neighbor& b) { return Closer{}(a, b); }

// The `keep` best neighbours in the caller's buffer: filled unordered until full, then kept as
// a max-heap (worst on top) with replace-top sift-down; sorted once at the end.
class NeighborHeap {
 public:
  NeighborHeap(Neighbor* data, std::size_t keep) : data_(data), keep_(keep) {}
  bool full() const { return size_ == keep_; }
  std::size_t size() const { return size_; }
  float worst() const { return data_[0].squared_distance; }
  void offer(const Neighbor& n) {
    if (size_ < keep_) {
      data_[size_++] = n;
      if (size_ == keep_) std::make_heap(data_, data_ + size_, Closer{});
    } else if (closer(n, data_[0])) {
      sift_down_from_top(n);
    }
  }
  void sort() { std::sort(data_, data_ + size_, Closer{}); }

 private:
  void sift_down_from_top(const Neighbor& n) {
    std::size_t hole = 0;
    for (;;) {
      std::size_t child = 2 * hole + 1;
      if (child >= size_) break;
      if (child + 1 < size_ && closer(data_[child], data_[child + 1])) ++child;
      if (!closer(n, data_[child])) break;
      data_[hole] = data_[child];
      hole = child;
    }
    data_[hole] = n;
  }

  Neighbor* data_;
  std::size_t keep_;
  std::size_t size_ = 0;
};

// Depth-first traversal with the incremental cell distance (Arya & Mount 1993; nanoflann's
// searchLevel), iterative so that the stack is a fixed array. off[d] is the query's squared
// offset from the current cell along axis d; cell_bound = sum of off[].
//   kVisit:   enter `node` whose cell is `cell_bound` away
//   kFar:     enter the far child `node`: set off[axis] = cut first (restored by kRestore)
//   kRestore: off[axis] = value (leaving a far subtree)
// leaf(node) scans a leaf; prune() gives the current pruning bound (squared distance).
struct Task {
  enum Kind : std::uint32_t { kVisit, kFar, kRestore };
  Kind kind;
  std::uint32_t node;
  std::uint32_t axis;
  float cell_bound;
  float value;
};
constexpr std::size_t kTraversalStack = 2 * config::kKdMaxDepth + 4;

template <int D, class Prune, class Leaf>
void traverse(const KdNode* nodes, const float* q, std::size_t max_visits, Prune prune,
              Leaf leaf, KdQueryResult& r) {
  float off[D];
  for (int d = 0; d < D; ++d) off[d] = 0.0f;
  Task stack[kTraversalStack];
  std::size_t top = 0;
  stack[top++] = {Task::kVisit, 0, 0, 0.0f, 0.0f};
  // The float-accumulated cell bound may be a few ulps high: shrink it so pruning stays exact.
  const auto prunable = [&prune](float cell_bound) { return cell_bound * 0.99999f > prune(); };
  while (top > 0) {
    const Task t = stack[--top];
    if (t.kind == Task::kRestore) {
      off[t.axis] = t.value;
      continue;
    }
    if (prunable(t.cell_bound)) continue;
    if (t.kind == Task::kFar) off[t.axis] = t.value;
    // Descend along near children without touching the stack; a far child is pushed only if
    // it cannot be pruned yet (the bound only shrinks, so a prunable one stays prunable).
    std::uint32_t id = t.node;
    for (;;) {
      if (r.node_visits >= max_visits) {
        r.visit_cap_hit = true;
        return;
      }
      ++r.node_visits;
      const KdNode& node = nodes[id];
      if (node.axis == KdNode::kLeaf) {
        leaf(node);
        break;
      }
      const float x = q[node.axis];
      const float to_left = x - node.left_max;    // > 0: query right of the left cell
      const float to_right = x - node.right_min;  // < 0: query left of the right cell
      const bool left_first = to_left + to_right < 0.0f;
      const float cut = left_first ? to_right * to_right : to_left * to_left;
      const float old = off[node.axis];
      const float far_bound = t.cell_bound - old + cut;
      if (!prunable(far_bound) && top + 2 <= kTraversalStack) {  // depth <= kKdMaxDepth
        stack[top++] = {Task::kRestore, 0, node.axis, 0.0f, old};
        stack[top++] = {Task::kFar, left_first ? node.second : node.first, node.axis, far_bound,
                        cut};
      }
      id = left_first ? node.first : node.second;
    }
  }
}

// Build step 1: the finite points' indices in input order; drops counted in `result`.
template <class P>
std::size_t index_finite_points(std::span<const P> points, std::span<std::uint32_t> index_storage,
                                KdBuildResult& result) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!is_finite_point(points[i])) {
      ++result.non_finite_dropped;
      continue;
    }
    if (n == index_storage.size()) {
      ++result.capacity_dropped;
      continue;
    }
    index_storage[n++] = static_cast<std::uint32_t>(i);
  }
  return n;
}

// Build step 2: the split axis of a node, the largest extent of its points (largest variance in
// high dimension); `extent` is the largest extent (0: all points identical).
template <class P>
int choose_split_axis(std::span<const P> points, const std::uint32_t* idx, const KdBuildTask& t,
                      float& extent) {
  constexpr int kDim = P::RowsAtCompileTime;
  const std::uint32_t count = t.end - t.begin;
  float lo[kDim];
  float hi[kDim];
  for (int d = 0; d < kDim; ++d) lo[d] = hi[d] = points[idx[t.begin]][d];
  if constexpr (kDim == 3) {
    // Spelled out: GCC -O2 kept the 3-step axis loop, which cost a third of a map build
    // (callgrind). The same min / max as below, so the same extents.
    float lx = lo[0], ly = lo[1], lz = lo[2], hx = hi[0], hy = hi[1], hz = hi[2];
    for (std::uint32_t s = t.begin + 1; s < t.end; ++s) {
      const float* p = points[idx[s]].data();
      lx = std::min(lx, p[0]);
      ly = std::min(ly, p[1]);
      lz = std::min(lz, p[2]);
      hx = std::max(hx, p[0]);
      hy = std::max(hy, p[1]);
      hz = std::max(hz, p[2]);
    }
    lo[0] = lx, lo[1] = ly, lo[2] = lz, hi[0] = hx, hi[1] = hy, hi[2] = hz;
  } else {
    for (std::uint32_t s = t.begin + 1; s < t.end; ++s) {
      const float* p = points[idx[s]].data();
      for (int d = 0; d < kDim; ++d) {
        lo[d] = std::min(lo[d], p[d]);
        hi[d] = std::max(hi[d], p[d]);
      }
    }
  }
  int axis = 0;
  extent = hi[0] - lo[0];
  for (int d = 1; d < kDim; ++d) {
    if (hi[d] - lo[d] > extent) {
      extent = hi[d] - lo[d];
      axis = d;
    }
  }
  if constexpr (kDim > 8) {
    // High dimension: split on the largest variance instead (extents are set by a few
    // outliers; FPFH spreads over many bins). Serial double sums: deterministic.
    double sum[kDim] = {};
    double sum2[kDim] = {};
    for (std::uint32_t s = t.begin; s < t.end; ++s) {
      const float* p = points[idx[s]].data();
      for (int d = 0; d < kDim; ++d) {
        sum[d] += p[d];
        sum2[d] += static_cast<double>(p[d]) * p[d];
      }
    }
    double best = -1.0;
    for (int d = 0; d < kDim; ++d) {
      const double var = sum2[d] - sum[d] * sum[d] / static_cast<double>(count);
      if (var > best && hi[d] > lo[d]) {
        best = var;
        axis = d;
      }
    }
  }
  return axis;
}

// Build step 3: the median along the axis at `mid` (ties by index: deterministic), smaller
// coordinates before it. Returns the left child's largest coordinate along the axis (equal
// values may sit on both sides of the median).
template <class P>
float partition_at_median(std::span<const P> points, std::uint32_t* idx, const KdBuildTask& t,
                          std::uint32_t mid, int axis) {
  std::nth_element(idx + t.begin, idx + mid, idx + t.end,
                   [&points, axis](std::uint32_t a, std::uint32_t b) {
                     const float va = points[a][axis];
                     const float vb = points[b][axis];
                     return va < vb || (va == vb && a < b);
                   });
  float left_max = points[idx[t.begin]][axis];
  for (std::uint32_t s = t.begin + 1; s < mid; ++s) {
    left_max = std::max(left_max, points[idx[s]][axis]);
  }
  return left_max;
}

}  // namespace

template <class P>
KdBuildResult KdTree<P>::build(std::span<const P> points, std::span<std::uint32_t> index_storage,
                               std::span<KdNode> node_storage, const KdBuildParams& params) {
  KdBuildResult result = begin_build(points, index_storage, node_storage, params);
  while (!build_step(~std::size_t{0}, result)) {
  }
  return result;
}

template <class P>
KdBuildResult KdTree<P>::begin_build(std::span<const P> points, std::span<std::uint32_t> index_storage,
                                     std::span<KdNode> node_storage, const KdBuildParams& params) {
  KdBuildResult result;
  points_ = points;
  projections_ = nullptr;
  indices_ = index_storage.data();
  nodes_ = node_storage.data();
  num_nodes_ = 0;
  num_indexed_ = 0;
  max_node_visits_ = params.max_node_visits;
  build_ = {};
  build_.leaf_size = params.leaf_size > 0 ? params.leaf_size : 1;
  build_.node_capacity = node_storage.size();
  build_.index = index_storage.data();
  build_.nodes = node_storage.data();

  const std::size_t n = index_finite_points(points, index_storage, result);
  result.points_indexed = static_cast<std::uint32_t>(n);
  if (n == 0) {
    result.status = KdBuildStatus::kEmpty;
    return result;
  }
  if (node_storage.empty()) {
    result.status = KdBuildStatus::kNodeStorageTooSmall;
    return result;
  }
  build_.points_indexed = n;
  build_.used = 1;
  build_.active = true;
  // Depth-first with an explicit stack (the bare-metal stack is small): <= depth + 1 entries.
  build_.stack[build_.top++] = {0, 0, static_cast<std::uint32_t>(n), 1};
  return result;
}

// Splits nodes (depth first, the order build() uses, so the tree is the same) until the points
// touched exceed work_budget; returns true when the tree is complete and queryable.
template <class P>
bool KdTree<P>::build_step(std::size_t work_budget, KdBuildResult& result) {
  std::size_t work = 0;
  std::uint32_t* idx = build_.index;
  KdNode* nodes = build_.nodes;
  while (build_.top > 0) {
    if (work >= work_budget) return false;
    const KdBuildTask t = build_.stack[--build_.top];
    KdNode& node = nodes[t.node];
    result.depth = std::max(result.depth, t.depth);
    const std::uint32_t count = t.end - t.begin;
    work += count;
    if (count <= build_.leaf_size || t.depth >= config::kKdMaxDepth) {
      node = {0.0f, 0.0f, t.begin, t.end, KdNode::kLeaf};
      continue;
    }
    float extent = 0.0f;
    const int axis = choose_split_axis(points_, idx, t, extent);
    if (extent <= 0.0f) {  // all points identical: nothing to split
      node = {0.0f, 0.0f, t.begin, t.end, KdNode::kLeaf};
      continue;
    }
    const std::uint32_t mid = t.begin + count / 2;
    // Children's extents along the axis: right starts at the selected element, left ends at
    // the largest coordinate below it.
    const float left_max = partition_at_median(points_, idx, t, mid, axis);
    if (build_.used + 2 > build_.node_capacity) {
      result.status = KdBuildStatus::kNodeStorageTooSmall;
      result.nodes = static_cast<std::uint32_t>(build_.used);
      build_.top = 0;
      build_.active = false;
      return true;
    }
    const auto left = static_cast<std::uint32_t>(build_.used);
    const auto right = static_cast<std::uint32_t>(build_.used + 1);
    build_.used += 2;
    node = {left_max, points_[idx[mid]][axis], left, right, static_cast<std::uint32_t>(axis)};
    build_.stack[build_.top++] = {right, mid, t.end, t.depth + 1};
    build_.stack[build_.top++] = {left, t.begin, mid, t.depth + 1};
  }
  if (!build_.active) return true;  // nothing indexed, begin_build failed, or already done
  build_.active = false;
  num_nodes_ = build_.used;
  num_indexed_ = build_.points_indexed;
  result.nodes = static_cast<std::uint32_t>(build_.used);
  result.status = result.capacity_dropped > 0 ? KdBuildStatus::kIndexStorageTooSmall
                                              : KdBuildStatus::kOk;
  return true;
}

template <class P>
KdQueryResult KdTree<P>::search(const P& query, std::size_t keep, float r2, bool exact_count,
                                std::size_t requested, std::span<Neighbor> out) const {
  KdQueryResult r;
  keep = std::min(keep, out.size());
  if (num_nodes_ == 0 || keep == 0 || !is_finite_point(query) || !(r2 >= 0.0f)) {
    // No room at all: report what could have been returned (an upper bound for radius queries).
    if (num_nodes_ != 0 && out.empty()) {
      r.truncated = static_cast<std::uint32_t>(std::min(requested, num_indexed_));
    }
    return r;
  }
  NeighborHeap heap(out.data(), keep);
  const float* q = query.data();
  std::size_t in_radius = 0;
  // Prune by the radius, tightened by the heap's worst once full (unless every in-radius point
  // must be counted for the truncation report).
  const auto prune = [&]() {
    return (!exact_count && heap.full()) ? std::min(r2, heap.worst()) : r2;
  };
  const auto leaf = [&](const KdNode& node) {
    for (std::uint32_t s = node.first; s < node.second; ++s) {
      const std::uint32_t i = indices_[s];
      const float bound = prune();
      const float d2 = squared_distance_bounded<kDim>(q, points_[i].data(), bound);
      if (d2 < r2) {  // strict, as nanoflann's radius and hybrid searches in Open3D
        ++in_radius;
        heap.offer({i, d2});
      }
    }
  };
  traverse<kDim>(nodes_, q, max_node_visits_, prune, leaf, r);
  heap.sort();
  r.count = static_cast<std::uint32_t>(heap.size());
  if (exact_count) {
    const std::size_t wanted = std::min(requested, in_radius);
    if (wanted > r.count) r.truncated = static_cast<std::uint32_t>(wanted - r.count);
  }
  return r;
}

template <class P>
KdQueryResult KdTree<P>::knn(const P& query, std::size_t k, std::span<Neighbor> out) const {
  if (k > out.size()) {
    // The buffer cannot hold k: keep what fits; the missing ones are those the tree could give.
    KdQueryResult r = search(query, out.size(), INFINITY, false, k, out);
    const std::size_t wanted = std::min(k, num_indexed_);
    if (wanted > r.count) r.truncated = static_cast<std::uint32_t>(wanted - r.count);
    return r;
  }
  return search(query, k, INFINITY, false, k, out);
}

template <class P>
KdQueryResult KdTree<P>::radius(const P& query, float radius, std::span<Neighbor> out) const {
  return search(query, out.size(), radius * radius, true, num_indexed_, out);
}

template <class P>
KdQueryResult KdTree<P>::hybrid(const P& query, float radius, std::size_t max_nn,
                                std::span<Neighbor> out) const {
  return search(query, max_nn, radius * radius, max_nn > out.size(), max_nn, out);
}

template <class P>
bool KdTree<P>::projection_rejects(const float* qp, std::uint32_t i, float bound) const {
  const float* cp = projections_ + static_cast<std::size_t>(i) * projection_stride_;
  float lb = 0.0f;
  for (int k = 0; k < kProjectionDim; ++k) {
    const float t = qp[k] - cp[k];
    lb += t * t;
  }
  // Margin: 1e-4 relative (float distance and lower-bound sums: ~1e-6) plus the absolute
  // projection-rounding term of set_projections; only truly farther points are rejected.
  return lb * 0.9999f > bound + projection_margin_;
}

template <class P>
KdQueryResult KdTree<P>::nearest_seeded(const P& query, Neighbor best, bool found,
                                        Neighbor& out, const float* qp) const {
  KdQueryResult r;
  const float* q = query.data();
  const bool filter = qp != nullptr && projections_ != nullptr;
  const auto prune = [&]() { return best.squared_distance; };
  const auto leaf = [&](const KdNode& node) {
    for (std::uint32_t s = node.first; s < node.second; ++s) {
      const std::uint32_t i = indices_[s];
      if (filter && found && projection_rejects(qp, i, best.squared_distance)) continue;
      const float d2 = squared_distance_bounded<kDim>(q, points_[i].data(), best.squared_distance);
      const Neighbor cand{i, d2};
      if (!found || closer(cand, best)) {
        best = cand;
        found = true;
      }
    }
  };
  traverse<kDim>(nodes_, q, max_node_visits_, prune, leaf, r);
  if (found) {
    out = best;
    r.count = 1;
  }
  return r;
}

template <class P>
KdQueryResult KdTree<P>::nearest(const P& query, Neighbor& out) const {
  if (num_nodes_ == 0 || !is_finite_point(query)) return {};
  return nearest_seeded(query, Neighbor{0, INFINITY}, false, out);
}

template <class P>
KdQueryResult KdTree<P>::nearest(const P& query, std::uint32_t hint, Neighbor& out) const {
  return nearest(query, nullptr, hint, out);
}

template <class P>
KdQueryResult KdTree<P>::nearest_within(const P& query, float max_squared_distance,
                                        std::uint32_t hint, Neighbor& out) const {
  if (num_nodes_ == 0 || !is_finite_point(query) || !(max_squared_distance >= 0.0f)) return {};
  if (max_squared_distance == 0.0f) max_squared_distance = 0.0f;  // -0 -> +0 (see Closer)
  // A sentinel at the bound with the largest index: closer() accepts exactly d2 <= bound.
  Neighbor seed{kNoHint, max_squared_distance};
  if (hint < points_.size() && is_finite_point(points_[hint])) {
    const float d2 = squared_distance_bounded<kDim>(query.data(), points_[hint].data(), INFINITY);
    if (d2 <= max_squared_distance) seed = {hint, d2};
  }
  Neighbor best{};
  KdQueryResult r = nearest_seeded(query, seed, true, best);
  if (best.index == kNoHint) {
    r.count = 0;
    return r;
  }
  out = best;
  return r;
}

template <class P>
KdQueryResult KdTree<P>::nearest(const P& query, const float* query_projection,
                                 Neighbor& out) const {
  return nearest(query, query_projection, kNoHint, out);
}

template <class P>
KdQueryResult KdTree<P>::nearest(const P& query, const float* query_projection,
                                 std::uint32_t hint, Neighbor& out) const {
  if (num_nodes_ == 0 || !is_finite_point(query)) return {};
  // Only an indexed point may seed the bound (a non-finite one is not in the tree).
  if (hint >= points_.size() || !is_finite_point(points_[hint])) {
    return nearest_seeded(query, Neighbor{0, INFINITY}, false, out, query_projection);
  }
  const Neighbor seed{hint, squared_distance_bounded<kDim>(query.data(), points_[hint].data(), INFINITY)};
  return nearest_seeded(query, seed, true, out, query_projection);
}

template <class P>
KdQueryResult KdTree<P>::has_closer(const P& query, const Neighbor& bound, bool& found) const {
  return has_closer(query, nullptr, bound, found);
}

template <class P>
KdQueryResult KdTree<P>::has_closer(const P& query, const float* qp, const Neighbor& bound,
                                    bool& found) const {
  KdQueryResult r;
  found = false;
  if (num_nodes_ == 0 || !is_finite_point(query)) return r;
  const float* q = query.data();
  const bool filter = qp != nullptr && projections_ != nullptr;
  // Once found, a negative bound prunes every remaining task (cell bounds are >= 0).
  const auto prune = [&]() { return found ? -1.0f : bound.squared_distance; };
  const auto leaf = [&](const KdNode& node) {
    for (std::uint32_t s = node.first; s < node.second && !found; ++s) {
      const std::uint32_t i = indices_[s];
      if (filter && projection_rejects(qp, i, bound.squared_distance)) continue;
      const float d2 = squared_distance_bounded<kDim>(q, points_[i].data(), bound.squared_distance);
      found = closer(Neighbor{i, d2}, bound);
    }
  };
  traverse<kDim>(nodes_, q, max_node_visits_, prune, leaf, r);
  r.count = found ? 1u : 0u;
  return r;
}

template <class P>
bool KdTree<P>::any_within(const P& query, float max_squared_distance, std::uint64_t* node_visits) const {
  if (num_nodes_ == 0 || !is_finite_point(query) || !(max_squared_distance >= 0.0f)) return false;
  const float* q = query.data();
  bool found = false;
  KdQueryResult r;
  // The traversal nearest_within makes with the same bound, up to the first point inside it.
  const auto prune = [&]() { return found ? -1.0f : max_squared_distance; };
  const auto leaf = [&](const KdNode& node) {
    for (std::uint32_t s = node.first; s < node.second && !found; ++s) {
      const std::uint32_t i = indices_[s];
      found = squared_distance_bounded<kDim>(q, points_[i].data(), max_squared_distance) <= max_squared_distance;
    }
  };
  traverse<kDim>(nodes_, q, max_node_visits_, prune, leaf, r);
  if (node_visits != nullptr) *node_visits += r.node_visits;
  return found;
}

template <class P>
float KdTree<P>::squared_distance(const P& a, const P& b) {
  return squared_distance_bounded<kDim>(a.data(), b.data(), INFINITY);
}

template class KdTree<Vec3f>;
template class KdTree<Feature33>;

}  // namespace v2xloc

namespace v2xloc {

static_assert(config::kMaxNeighbors < 255, "KdNeighborhoods stores list lengths in 8 bits");

void KdNeighborhoods::build(float radius, std::size_t max_nn, std::span<Slot> entries,
                            std::span<std::uint32_t> begin, std::span<std::uint8_t> count) {
  radius_ = radius;
  max_nn_ = max_nn < config::kMaxNeighbors ? max_nn : config::kMaxNeighbors;
  entries_ = entries.data();
  begin_ = begin.data();
  count_ = count.data();
  cached_points_ = 0;
  not_cached_ = 0;
  build_search_ = {};
  const std::span<const Vec3f> points = tree_->points();
  const std::size_t n = points.size();
  if (entries.empty() || begin.size() < n || count.size() < n || n > kMaxTreePoints ||
      !(radius > 0.0f) || max_nn_ == 0) {
    count_ = nullptr;  // nothing cached: every get() searches
    not_cached_ = static_cast<std::uint32_t>(n);
    return;
  }
  Neighbor buffer[config::kMaxNeighbors];
  std::size_t used = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const KdQueryResult r = tree_->hybrid(points[i], radius, max_nn_,
                                          std::span<Neighbor>(buffer, max_nn_));
    build_search_.add(r);
    if (used + r.count > entries.size()) {  // pool full: this and the rest are searched later
      for (std::size_t rest = i; rest < n; ++rest) count[rest] = kNotCached;
      not_cached_ += static_cast<std::uint32_t>(n - i);
      break;
    }
    begin[i] = static_cast<std::uint32_t>(used);
    count[i] = static_cast<std::uint8_t>(r.count);
    for (std::uint32_t k = 0; k < r.count; ++k) {
      entries[used++] = static_cast<Slot>(buffer[k].index);
    }
    ++cached_points_;
  }
}

KdQueryResult KdNeighborhoods::get(std::size_t i, float radius, std::size_t max_nn,
                                   std::span<Neighbor> out) const {
  const std::span<const Vec3f> points = tree_->points();
  if (count_ == nullptr || count_[i] == kNotCached || !(radius <= radius_) || max_nn > max_nn_ ||
      out.size() < max_nn) {
    return tree_->hybrid(points[i], radius, max_nn, out);
  }
  KdQueryResult r;
  const float r2 = radius * radius;
  const Vec3f& p = points[i];
  const Slot* list = entries_ + begin_[i];
  const std::uint32_t n = count_[i];
  std::uint32_t k = 0;
  for (std::uint32_t e = 0; e < n && k < max_nn; ++e) {
    const std::uint32_t j = list[e];
    const float d2 = KdTree<Vec3f>::squared_distance(p, points[j]);
    if (!(d2 < r2)) break;  // ascending: the rest is outside the smaller radius too
    out[k++] = {j, d2};
  }
  r.count = k;
  return r;
}

}  // namespace v2xloc
