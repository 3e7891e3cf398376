// Static k-d tree over a caller-owned span of points (3-D Vec3f or 33-D Feature33), with
// caller-owned index and node storage: building and querying never allocate.
//
// Build: median split (selection by (coordinate, index), a strict total order, so the tree is the
// same on every machine) on the axis of largest spread (3-D: extent; 33-D: variance, which
// extents set by a few outliers misjudge); leaves hold <= leaf_size points; O(N log N).
// Non-finite points are not indexed (counted).
// Queries write into caller buffers and return a KdQueryResult:
//   knn      k nearest, ascending (squared_distance, index)
//   radius   all with squared distance < radius^2 (strict, like nanoflann), ascending; if the
//            buffer is too small the nearest out.size() are kept, the rest counted in `truncated`
//   hybrid   Open3D 0.16 KDTreeSearchParamHybrid: of the max_nn nearest, those with squared
//            distance < radius^2, ascending
//   nearest  the single nearest neighbour (fast path); optionally warm-started from a hint
//            point (e.g. last ICP iteration's match): its distance is the initial bound, which
//            prunes most of the tree, and the result is still the exact nearest
//   has_closer  whether any point is strictly closer (distance, then index) than a given
//            neighbour; stops at the first one found (mutual-match checks)
// Pruning uses the incremental cell distance of Arya & Mount (nanoflann): the squared distance
// from the query to a node's cell accumulated over all axes.
// Traversal is bounded: an explicit stack of 2 * config::kKdMaxDepth entries and at most
// max_node_visits nodes per query (default config::kKdMaxNodeVisits); when the cap is hit the
// best-so-far result is returned and visit_cap_hit is set.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

// The float squared distance for "within radius" queries (any_within, nearest_within): radius^2
// rounded down, never up, so that no point beyond the radius counts.
inline float squared_radius_not_above(double radius) {
  const double r2 = radius * radius;
  float f = static_cast<float>(r2);
  if (static_cast<double>(f) > r2) f = std::nextafter(f, 0.0f);
  return f;
}

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

// A node still to be split during a build (depth first).
struct KdBuildTask {
  std::uint32_t node;
  std::uint32_t begin;
  std::uint32_t end;
  std::uint32_t depth;
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

  // The same build spread over several calls (a map rebuilt beside the registration, a bounded
  // amount per period): begin_build indexes the points (O(N)); each build_step splits nodes
  // until the points it touched exceed work_budget, and returns true once the tree is complete.
  // The tree answers no query (empty()) until then; the result is bit-identical to build().
  KdBuildResult begin_build(std::span<const P> points, std::span<std::uint32_t> index_storage,
                            std::span<KdNode> node_storage, const KdBuildParams& params = {});
  bool build_step(std::size_t work_budget, KdBuildResult& result);
  // Work a spread build still has to do, in build_step's units (points touched), at most: each
  // pending node's points once per level down to the leaves (the larger half at every split).
  // build_step(q) finishes the tree when this is <= q. 0 when idle.
  std::size_t build_work_left() const {
    std::size_t work = 0;
    for (std::size_t i = 0; i < build_.top; ++i) {
      const std::size_t n = build_.stack[i].end - build_.stack[i].begin;
      for (std::size_t m = n; m > build_.leaf_size; m = (m + 1) / 2) work += n;
      work += n;
    }
    return work;
  }

  KdQueryResult knn(const P& query, std::size_t k, std::span<Neighbor> out) const;
  KdQueryResult radius(const P& query, float radius, std::span<Neighbor> out) const;
  KdQueryResult hybrid(const P& query, float radius, std::size_t max_nn,
                       std::span<Neighbor> out) const;
  // count == 0 when the tree is empty (out untouched) or the query is not finite.
  KdQueryResult nearest(const P& query, Neighbor& out) const;
  // Same result as nearest(); `hint` (an index into points(), ignored when out of range or not
  // finite) seeds the search bound.
  KdQueryResult nearest(const P& query, std::uint32_t hint, Neighbor& out) const;
  // The nearest neighbour if its squared distance is <= max_squared_distance (count 1), else
  // count 0: the same neighbour nearest() gives whenever that one is within the bound, found
  // without exploring beyond it (ICP correspondences with a distance gate). hint as above.
  KdQueryResult nearest_within(const P& query, float max_squared_distance, std::uint32_t hint,
                               Neighbor& out) const;
  static constexpr std::uint32_t kNoHint = 0xFFFFFFFFu;
  // Whether some point lies within squared distance max_squared_distance (inclusive): exactly
  // nearest_within(...).count > 0, but it stops at the first such point (hypothesis scoring).
  // node_visits (optional): incremented by the nodes visited.
  bool any_within(const P& query, float max_squared_distance, std::uint64_t* node_visits = nullptr) const;
  // found = some indexed point n has (d2(query, n), n.index) < (bound.squared_distance,
  // bound.index). count = 1 when found.
  KdQueryResult has_closer(const P& query, const Neighbor& bound, bool& found) const;

  // Optional exact pre-filter of leaf scans (high dimension): per point its coordinates in
  // kProjectionDim orthonormal directions (e.g. the features' principal axes), point i at
  // first[i * stride]. The squared distance of two projections is a lower bound of the full
  // one, so most candidates are rejected after kProjectionDim terms instead of 16 or 33; a
  // margin above the rounding error keeps every result exactly that of the plain search.
  // Queries pass their own projection (same basis); nullptr: no filter for that query.
  static constexpr int kProjectionDim = 8;
  // max_abs: the largest |coordinate| among the stored and the query projections (sets the
  // absolute rounding margin). A rebuild clears the projections.
  void set_projections(const float* first, std::size_t stride, float max_abs) {
    projections_ = first;
    projection_stride_ = stride;
    // Projections rounded to float (relative 2^-24 ~ 6e-8 of <= max_abs) move the lower bound
    // by <= ~11.3e-7 max_abs sqrt(lb); that stays below 1e-4 lb + 4e-9 max_abs^2 for all lb.
    projection_margin_ = 4e-9f * max_abs * max_abs + 1e-30f;
  }
  KdQueryResult nearest(const P& query, const float* query_projection, Neighbor& out) const;
  // Both: the projection filter and a hint that seeds the bound (e.g. the match of a similar
  // query). Same result as nearest(query, out); a good hint only saves work.
  KdQueryResult nearest(const P& query, const float* query_projection, std::uint32_t hint,
                        Neighbor& out) const;
  KdQueryResult has_closer(const P& query, const float* query_projection, const Neighbor& bound,
                           bool& found) const;
  // The squared distance exactly as the queries compute it (float, fixed summation order):
  // comparing it with a query's squared_distance is bit-exact.
  static float squared_distance(const P& a, const P& b);

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
  KdQueryResult nearest_seeded(const P& query, Neighbor best, bool found, Neighbor& out,
                               const float* query_projection = nullptr) const;
  // True when the projections prove squared_distance(query, point i) > bound.
  bool projection_rejects(const float* query_projection, std::uint32_t i, float bound) const;

  struct BuildState {
    KdBuildTask stack[config::kKdMaxDepth + 2];
    std::size_t top = 0;
    std::size_t used = 0;
    std::size_t leaf_size = 1;
    std::size_t node_capacity = 0;
    std::size_t points_indexed = 0;
    std::uint32_t* index = nullptr;
    KdNode* nodes = nullptr;
    bool active = false;
  };

  std::span<const P> points_{};
  BuildState build_{};
  const std::uint32_t* indices_ = nullptr;
  const KdNode* nodes_ = nullptr;
  std::size_t num_nodes_ = 0;
  std::size_t num_indexed_ = 0;
  std::size_t max_node_visits_ = config::kKdMaxNodeVisits;
  const float* projections_ = nullptr;
  std::size_t projection_stride_ = 0;
  float projection_margin_ = 0.0f;
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
    return tree.build(points, index_span(), node_span(), params(max_node_visits));
  }
  KdBuildResult begin_build(std::span<const P> points,
                            std::size_t max_node_visits = config::kKdMaxNodeVisits) {
    return tree.begin_build(points, index_span(), node_span(), params(max_node_visits));
  }

 private:
  std::span<std::uint32_t> index_span() { return {indices, N}; }
  std::span<KdNode> node_span() { return {nodes, kd_max_nodes(N, LeafSize)}; }
  static KdBuildParams params(std::size_t max_node_visits) {
    KdBuildParams p;
    p.leaf_size = LeafSize;
    p.max_node_visits = max_node_visits;
    return p;
  }
};

}  // namespace v2xloc

namespace v2xloc {

// Hybrid-search neighbourhoods (radius, max_nn) of every point of a 3-D tree, searched once and
// shared by the stages that need them (normals and both FPFH passes: one search per point
// instead of three). A consumer asking for (radius', max_nn') with radius' <= radius and
// max_nn' <= max_nn gets the prefix of the cached list with squared distance < radius'^2, which
// is exactly what hybrid(radius', max_nn') returns (the list is sorted by (distance, index)).
// Lists are stored as 16-bit indices in caller storage; a point whose list does not fit (storage
// exhausted, tree > 65536 points) is re-searched on request (counted in not_cached): the
// results never depend on the capacity. Squared distances are recomputed bit-exactly.
class KdNeighborhoods {
 public:
  using Slot = std::uint16_t;
  static constexpr std::size_t kMaxTreePoints = 65536;

  // Without storage: every request is a search (the stages' plain entry points use this).
  explicit KdNeighborhoods(const KdTree<Vec3f>& tree) : tree_(&tree) {}

  // Searches every point of tree.points() (non-finite points get an empty list). entries: the
  // index pool; begin / count: one per point (>= tree.points().size(), else nothing is cached).
  void build(float radius, std::size_t max_nn, std::span<Slot> entries,
             std::span<std::uint32_t> begin, std::span<std::uint8_t> count);

  // Neighbours of point i within radius (strict) / the max_nn nearest, ascending, into out
  // (out.size() >= max_nn), as tree().hybrid(points[i], radius, max_nn, out).
  KdQueryResult get(std::size_t i, float radius, std::size_t max_nn, std::span<Neighbor> out) const;

  const KdTree<Vec3f>& tree() const { return *tree_; }
  std::uint32_t cached_points() const { return cached_points_; }
  std::uint32_t not_cached() const { return not_cached_; }   // points left to re-search
  const KdQueryCounters& build_search() const { return build_search_; }

 private:
  static constexpr std::uint8_t kNotCached = 0xFF;
  const KdTree<Vec3f>* tree_;
  float radius_ = 0.0f;
  std::size_t max_nn_ = 0;
  const Slot* entries_ = nullptr;
  const std::uint32_t* begin_ = nullptr;
  const std::uint8_t* count_ = nullptr;
  std::uint32_t cached_points_ = 0;
  std::uint32_t not_cached_ = 0;
  KdQueryCounters build_search_{};
};

}  // namespace v2xloc
