#include "v2xloc/algo/kdtree.hpp"

#include <algorithm>
#include <cmath>

namespace v2xloc {
namespace {

template <class P>
bool is_finite_point(const P& p) {
  const float* a = p.data();
  for (int d = 0; d < P::RowsAtCompileTime; ++d) {
    if (!std::isfinite(a[d])) return false;
  }
  return true;
}

// Squared distance in float, serial sum (same bits everywhere with -ffp-contract=off).
template <int D>
inline float squared_distance(const float* a, const float* b) {
  float s = 0.0f;
  for (int d = 0; d < D; ++d) {
    const float t = a[d] - b[d];
    s += t * t;
  }
  return s;
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

// Strict total order of neighbours: distance, then index (deterministic ties). A function
// object, so the heap algorithms inline it.
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
  while (top > 0) {
    const Task t = stack[--top];
    if (t.kind == Task::kRestore) {
      off[t.axis] = t.value;
      continue;
    }
    // The float-accumulated cell bound may be a few ulps high: shrink it so pruning stays exact.
    if (t.cell_bound * 0.99999f > prune()) continue;
    if (r.node_visits >= max_visits) {
      r.visit_cap_hit = true;
      return;
    }
    ++r.node_visits;
    if (t.kind == Task::kFar) off[t.axis] = t.value;
    const KdNode& node = nodes[t.node];
    if (node.axis == KdNode::kLeaf) {
      leaf(node);
      continue;
    }
    const float x = q[node.axis];
    const float to_left = x - node.left_max;    // > 0: query right of the left cell
    const float to_right = x - node.right_min;  // < 0: query left of the right cell
    const bool left_first = to_left + to_right < 0.0f;
    const std::uint32_t near_child = left_first ? node.first : node.second;
    const std::uint32_t far_child = left_first ? node.second : node.first;
    const float cut = left_first ? to_right * to_right : to_left * to_left;
    const float old = off[node.axis];
    const float far_bound = t.cell_bound - old + cut;
    if (top + 3 > kTraversalStack) continue;  // cannot happen: depth <= kKdMaxDepth
    stack[top++] = {Task::kRestore, 0, node.axis, 0.0f, old};
    stack[top++] = {Task::kFar, far_child, node.axis, far_bound, cut};
    stack[top++] = {Task::kVisit, near_child, node.axis, t.cell_bound, 0.0f};
  }
}

struct BuildTask {
  std::uint32_t node;
  std::uint32_t begin;
  std::uint32_t end;
  std::uint32_t depth;
};

}  // namespace

template <class P>
KdBuildResult KdTree<P>::build(std::span<const P> points, std::span<std::uint32_t> index_storage,
                               std::span<KdNode> node_storage, const KdBuildParams& params) {
  KdBuildResult result;
  points_ = points;
  indices_ = index_storage.data();
  nodes_ = node_storage.data();
  num_nodes_ = 0;
  num_indexed_ = 0;
  max_node_visits_ = params.max_node_visits;
  const std::size_t leaf_size = params.leaf_size > 0 ? params.leaf_size : 1;

  // Index the finite points in input order.
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
  result.points_indexed = static_cast<std::uint32_t>(n);
  if (n == 0) {
    result.status = KdBuildStatus::kEmpty;
    return result;
  }
  if (node_storage.empty()) {
    result.status = KdBuildStatus::kNodeStorageTooSmall;
    return result;
  }

  std::uint32_t* idx = index_storage.data();
  KdNode* nodes = node_storage.data();
  std::size_t used = 1;
  // Depth-first with an explicit stack (the bare-metal stack is small): <= depth + 1 entries.
  BuildTask stack[config::kKdMaxDepth + 2];
  std::size_t top = 0;
  stack[top++] = {0, 0, static_cast<std::uint32_t>(n), 1};
  while (top > 0) {
    const BuildTask t = stack[--top];
    KdNode& node = nodes[t.node];
    result.depth = std::max(result.depth, t.depth);
    const std::uint32_t count = t.end - t.begin;
    if (count <= leaf_size || t.depth >= config::kKdMaxDepth) {
      node = {0.0f, 0.0f, t.begin, t.end, KdNode::kLeaf};
      continue;
    }
    // Split axis: largest extent of the node's points.
    float lo[kDim];
    float hi[kDim];
    for (int d = 0; d < kDim; ++d) lo[d] = hi[d] = points[idx[t.begin]][d];
    for (std::uint32_t s = t.begin + 1; s < t.end; ++s) {
      const float* p = points[idx[s]].data();
      for (int d = 0; d < kDim; ++d) {
        lo[d] = std::min(lo[d], p[d]);
        hi[d] = std::max(hi[d], p[d]);
      }
    }
    int axis = 0;
    float extent = hi[0] - lo[0];
    for (int d = 1; d < kDim; ++d) {
      if (hi[d] - lo[d] > extent) {
        extent = hi[d] - lo[d];
        axis = d;
      }
    }
    if (extent <= 0.0f) {  // all points identical: nothing to split
      node = {0.0f, 0.0f, t.begin, t.end, KdNode::kLeaf};
      continue;
    }
    const std::uint32_t mid = t.begin + count / 2;
    std::nth_element(idx + t.begin, idx + mid, idx + t.end,
                     [&points, axis](std::uint32_t a, std::uint32_t b) {
                       const float va = points[a][axis];
                       const float vb = points[b][axis];
                       return va < vb || (va == vb && a < b);
                     });
    if (used + 2 > node_storage.size()) {
      result.status = KdBuildStatus::kNodeStorageTooSmall;
      result.nodes = static_cast<std::uint32_t>(used);
      return result;
    }
    const auto left = static_cast<std::uint32_t>(used);
    const auto right = static_cast<std::uint32_t>(used + 1);
    used += 2;
    // Children's extents along the axis: right starts at the selected element, left ends at
    // the largest coordinate below it (equal values may sit on both sides).
    float left_max = points[idx[t.begin]][axis];
    for (std::uint32_t s = t.begin + 1; s < mid; ++s) {
      left_max = std::max(left_max, points[idx[s]][axis]);
    }
    node = {left_max, points[idx[mid]][axis], left, right, static_cast<std::uint32_t>(axis)};
    stack[top++] = {right, mid, t.end, t.depth + 1};
    stack[top++] = {left, t.begin, mid, t.depth + 1};
  }
  num_nodes_ = used;
  num_indexed_ = n;
  result.nodes = static_cast<std::uint32_t>(used);
  result.status = result.capacity_dropped > 0 ? KdBuildStatus::kIndexStorageTooSmall
                                              : KdBuildStatus::kOk;
  return result;
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
KdQueryResult KdTree<P>::nearest(const P& query, Neighbor& out) const {
  KdQueryResult r;
  if (num_nodes_ == 0 || !is_finite_point(query)) return r;
  const float* q = query.data();
  Neighbor best{0, INFINITY};
  bool found = false;
  const auto prune = [&]() { return best.squared_distance; };
  const auto leaf = [&](const KdNode& node) {
    for (std::uint32_t s = node.first; s < node.second; ++s) {
      const std::uint32_t i = indices_[s];
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

template class KdTree<Vec3f>;
template class KdTree<Feature33>;

}  // namespace v2xloc
