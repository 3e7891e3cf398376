// Static k-d tree over a caller-owned span of points (3-D Vec3f or 33-D Feature33), with
// caller-owned index and node storage: building and querying never allocate.
//
// Build: median split (selection by (coordinate, index), a strict total order, so the tree is the
// same on every machine) on the axis of largest spread; leaves hold <= leaf_size points;
// O(N log N). Non-finite points are not indexed (counted).
// Queries write into caller buffers and return a KdQueryResult:
//   knn      k nearest, ascending (squared_distance, index)
//   radius   all with squared distance < radius^2 (strict, like nanoflann), ascending; if the
//            buffer is too small the nearest out.size() are kept, the rest counted in `truncated`
//   hybrid   Open3D 0.16 KDTreeSearchParamHybrid: of the max_nn nearest, those with squared
//            distance < radius^2, ascending
//   nearest  the single nearest neighbour (fast path)
// Pruning uses the incremental cell distance of Arya & Mount (nanoflann): the squared distance
// from the query to a node's cell accumulated over all axes.
// Traversal is bounded: an explicit stack of 2 * config::kKdMaxDepth entries and at most
// max_node_visits nodes per query (default config::kKdMaxNodeVisits); when the cap is hit the
// best-so-far result is returned and visit_cap_hit is set.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/config.hpp"
#include "v2xloc/algo/types.hpp"

namespace v2xloc {

struct Neighbor {
  std::uint32_t index;      // into the span the tree was built over
  float squared_distance;
};

// One tree node (20 bytes; opaque to callers). Leaves: [first, second) are slots of the index
// storage. Internal nodes: first/second are the left/right child node ids; left_max / right_min
// the extent of the children along `axis` (tighter bounds than a single split value).
struct KdNode {
  static constexpr std::uint32_t kLeaf = 0xFFFFFFFFu;
  float left_max = 0.0f;
  float right_min = 0.0f;
  std::uint32_t first = 0;
  std::uint32_t second = 0;
  std::uint32_t axis = kLeaf;
};

enum class KdBuildStatus : std::uint8_t {
  kOk,
  kEmpty,                   // no finite point (queries return 0 neighbours)
  kIndexStorageTooSmall,    // index storage < number of points: extra points not indexed
  kNodeStorageTooSmall,     // node storage exhausted: tree unusable
};

struct KdBuildParams {
  std::size_t leaf_size = config::kKdLeafSize;
  std::size_t max_node_visits = config::kKdMaxNodeVisits;  // per query
};

struct KdBuildResult {
  KdBuildStatus status = KdBuildStatus::kEmpty;
  std::uint32_t points_indexed = 0;
  std::uint32_t non_finite_dropped = 0;
  std::uint32_t capacity_dropped = 0;   // points beyond the index storage
  std::uint32_t nodes = 0;
  std::uint32_t depth = 0;
};

struct KdQueryResult {
  std::uint32_t count = 0;          // neighbours written to the output buffer
  std::uint32_t truncated = 0;      // neighbours that qualified but did not fit in the buffer
  std::uint32_t node_visits = 0;
  bool visit_cap_hit = false;       // traversal stopped early: result is best-so-far
};

// Sums per-query results over a stage (stages report these in their own result structs).
struct KdQueryCounters {
  std::uint64_t queries = 0;
  std::uint64_t node_visits = 0;
  std::uint64_t truncated = 0;
  std::uint64_t visit_cap_hits = 0;
  void add(const KdQueryResult& r) {
    ++queries;
    node_visits += r.node_visits;
    truncated += r.truncated;
    visit_cap_hits += r.visit_cap_hit ? 1u : 0u;
  }
};

// Upper bound on the nodes a tree over n points needs: every leaf of a split node holds at least
// floor((leaf_size + 1) / 2) points, so leaves <= n / that, nodes = 2 * leaves - 1.
constexpr std::size_t kd_max_nodes(std::size_t n, std::size_t leaf_size = config::kKdLeafSize) {
  const std::size_t min_leaf = (leaf_size + 1) / 2 > 0 ? (leaf_size + 1) / 2 : 1;
  const std::size_t leaves = n / min_leaf + 1;
  return 2 * leaves;
}

// P: Eigen::Matrix<float, D, 1> (instantiated for Vec3f and Feature33).
template <class P>
class KdTree {
 public:
  static constexpr int kDim = P::RowsAtCompileTime;

  KdTree() = default;

  // points must stay alive and unchanged while the tree is used. index_storage needs
  // points.size() slots, node_storage kd_max_nodes(points.size(), leaf_size) nodes.
  KdBuildResult build(std::span<const P> points, std::span<std::uint32_t> index_storage,
                      std::span<KdNode> node_storage, const KdBuildParams& params = {});

  KdQueryResult knn(const P& query, std::size_t k, std::span<Neighbor> out) const;
  KdQueryResult radius(const P& query, float radius, std::span<Neighbor> out) const;
  KdQueryResult hybrid(const P& query, float radius, std::size_t max_nn,
                       std::span<Neighbor> out) const;
  // count == 0 when the tree is empty (out untouched) or the query is not finite.
  KdQueryResult nearest(const P& query, Neighbor& out) const;

  bool empty() const { return num_nodes_ == 0; }
  std::size_t size() const { return num_indexed_; }
  std::span<const P> points() const { return points_; }
  void set_max_node_visits(std::size_t v) { max_node_visits_ = v; }
  std::size_t max_node_visits() const { return max_node_visits_; }

 private:
  // Shared bounded best-first search: keeps the `keep` nearest within r2 (inclusive).
  // exact_count: count every point within r2 (pruning by radius only) for truncation reports.
  KdQueryResult search(const P& query, std::size_t keep, float r2, bool exact_count,
                       std::size_t requested, std::span<Neighbor> out) const;

  std::span<const P> points_{};
  const std::uint32_t* indices_ = nullptr;
  const KdNode* nodes_ = nullptr;
  std::size_t num_nodes_ = 0;
  std::size_t num_indexed_ = 0;
  std::size_t max_node_visits_ = config::kKdMaxNodeVisits;
};

extern template class KdTree<Vec3f>;
extern template class KdTree<Feature33>;

// A tree with its storage, sized in the type. Large: declare it static.
//   static KdTreeStorage<Vec3f, config::kMaxMapPoints> map_tree;
//   map_tree.build(points);  map_tree.tree.knn(q, 10, buf);
template <class P, std::size_t N,
          std::size_t LeafSize = (P::RowsAtCompileTime > 8 ? config::kKdFeatureLeafSize
                                                           : config::kKdLeafSize)>
struct KdTreeStorage {
  static constexpr std::size_t kCapacity = N;
  KdTree<P> tree;
  std::uint32_t indices[N];
  KdNode nodes[kd_max_nodes(N, LeafSize)];

  KdBuildResult build(std::span<const P> points,
                      std::size_t max_node_visits = config::kKdMaxNodeVisits) {
    KdBuildParams params;
    params.leaf_size = LeafSize;
    params.max_node_visits = max_node_visits;
    return tree.build(points, std::span<std::uint32_t>(indices, N),
                      std::span<KdNode>(nodes, kd_max_nodes(N, LeafSize)), params);
  }
};

}  // namespace v2xloc
