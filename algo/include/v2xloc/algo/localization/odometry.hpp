// Online LiDAR odometry after KISS-ICP (Vizzo et al., "KISS-ICP: In Defense of Point-to-Point ICP",
// RA-L 2023), our own allocation-free code:
//   1. constant-velocity prediction  T_pred = T_{k-1} * delta_{k-1}                      (Sec. III-A)
//      (or the caller's prediction from wheel speed and yaw rate when it has one)
//   2. double voxelisation of the (deskewed) scan: 0.5 v for the map, 1.5 v as ICP source (III-B)
//   3. adaptive threshold: model deviation dT = T_pred^-1 T_k, delta = 2 r_max sin(theta/2) + |t|,
//      sigma = sqrt(mean delta^2 over frames with motion), tau = 3 sigma          (eqs. 4-6, III-C)
//   4. ICP against the local map with a Geman-McClure kernel kappa = sigma / 3, nearest neighbour
//      among the points of the 27 voxels around each source point (III-D). Residual: point-to-
//      point as KISS-ICP, or (default) point-to-plane along the *source* point's normal (PCA over
//      the 0.5 v frame). Why: on a flat road a LiDAR's ground rings move with the sensor; point-to-
//      point residuals between this frame's rings and the last frame's pull the estimate back
//      to the previous pose (measured: the odometry stalled at 0 m while the car drove 8 m).
//      Along the ground normal those residuals only constrain z, roll and pitch.
//   5. map update: <= max points per voxel, voxels farther than max_range from the sensor evicted.
// Choice vs the shared ICP (icp.hpp): that ICP wants a k-d tree built over a fixed target; the local
// map changes every frame, and a rebuild over ~1e5 points per frame costs more than the voxel-
// neighbour search, which the voxel hash gives for free. The Gauss-Newton step is 6x6 like theirs.
// Serial, ordered reductions (no TBB): the same bits on every ISA.
// Storage: the map (double-buffered for compaction), its voxel index, the frame buffers and each
// registration point's remembered voxel block live in the object (sizeof: 17.6 MB host, 2.13 MB
// EMBEDDED; the raw-sweep path's OdometryScanBuffers another 6.8 / 0.85 MB): static storage only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "v2xloc/algo/core/bounded_vector.hpp"
#include "v2xloc/algo/search/kdtree.hpp"
#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"
#include "v2xloc/algo/localization/odometry_map.hpp"
#include "v2xloc/algo/localization/pose_types.hpp"
#include "v2xloc/algo/registration/voxel_downsample.hpp"

namespace v2xloc {

struct OdometryParams {
  double voxel_size = 1.0;      // [m] local-map voxel v (KISS-ICP: max_range / 100)
  double max_range = 100.0;     // [m] scan points beyond are dropped; map eviction radius
  double min_range = 1.0;       // [m] drops returns from the ego vehicle itself
  // Clamped to config::kOdometryMaxPointsPerVoxel. KISS-ICP's 20 fit a map of ~10^5 points; the
  // EMBEDDED map (16,384) filled with 20 a voxel within five frames (~3,400 voxels) and refused
  // the street ahead: 2 a voxel keep ~8,500 voxels (algo/TUNING.md, "EMBEDDED: 2 points a voxel").
  std::uint32_t max_points_per_voxel = config::kEmbeddedProfile ? 2 : 20;
  double initial_threshold = 2.0;  // [m] sigma_0 until motion statistics exist
  double min_motion = 0.1;      // [m] model deviations below this are not sampled (no motion)
  std::uint32_t max_iterations = 50;   // clamped to config::kOdometryMaxIterations
  double convergence = 1e-4;    // stop when |d xi| (m, rad) < this
  bool point_to_plane = true;   // residual along the source normal (see the header comment)
  // [points] fine points a source normal's PCA needs (over the 2x2x2 coarse voxels around the
  // point, ~3 v wide); fewer: the point has no normal and is not registered.
  std::uint32_t normal_min_points = 5;
  // [queries] per frame (registration points x iterations): the iterations stop before
  // exceeding it, as at max_iterations (0: none; the localizer sets one for its period budget).
  std::uint32_t max_queries = 0;
  // [points] a pre-voxelised frame (register_voxelized_frame) is thinned evenly to at most this
  // many 0.5 v points (0: none; the localizer sets one for its period budget).
  std::uint32_t max_fine_points = 0;
  // [points] a pre-voxelised frame keeps every k-th 0.5 v point (1: all), before max_fine_points.
  std::uint32_t fine_decimation = 1;
};

enum class OdometryStatus : std::uint8_t {
  kOk,
  kFirstFrame,        // map initialised, pose = initial
  kEmptyScan,         // no usable point: pose = prediction, map unchanged
  kNoCorrespondences, // nothing within tau: pose = prediction
  kDegenerate,        // normal matrix not positive definite: pose = last estimate
};

struct OdometryResult {
  OdometryStatus status = OdometryStatus::kEmptyScan;
  Pose3d pose = Pose3d::Identity();   // world(odom)_T_sensor after this frame
  Pose3d delta = Pose3d::Identity();  // T_{k-1}^-1 T_k
  double threshold = 0.0;             // tau [m] used this frame
  double sigma = 0.0;                 // adaptive sigma [m]
  double rmse = 0.0;                  // [m] over correspondences of the final iteration
  std::uint32_t iterations = 0;
  bool converged = false;
  bool query_capped = false;          // max_queries ended the iterations
  std::uint32_t fine_points_skipped = 0;  // 0.5 v points left out (fine_decimation, max_fine_points)
  bool fine_points_capped = false;        // max_fine_points thinned the frame further
  std::uint32_t source_points = 0;    // 1.5 v points registered
  std::uint32_t correspondences = 0;
  std::uint32_t map_points = 0;
  std::uint32_t map_voxels = 0;
  std::uint32_t points_dropped_range = 0;     // outside [min_range, max_range] or non-finite
  std::uint32_t points_dropped_capacity = 0;  // frame or map buffers full, hash probes exhausted
  std::uint32_t voxels_evicted = 0;
};

// The raw-sweep path's scratch (LidarOdometry::register_frame): the range-filtered returns and the
// fine voxel table. The caller's, not every odometry's: the localizer's scan ingest voxelises the
// sweep once (register_voxelized_frame), so its odometry would carry ~0.8 MiB (EMBEDDED) unused.
struct OdometryScanBuffers {
  VoxelDownsampleStorage<config::kVoxelHashSlots, config::kMaxDownsampledPoints> downsample;
  FixedVector<Vec3f, config::kMaxScanPoints> in_range;
};

class LidarOdometry {
 public:
  explicit LidarOdometry(const OdometryParams& params = {});
  LidarOdometry(const LidarOdometry&) = delete;
  LidarOdometry& operator=(const LidarOdometry&) = delete;
  // New parameters (clamped) and reset(): the object is not assignable (it lives in static storage).
  void configure(const OdometryParams& params);
  // Clears the map; the next frame starts at `initial` (world_T_sensor).
  void reset(const Pose3d& initial = Pose3d::Identity());
  // One deskewed scan in the sensor frame. predicted_delta (optional): the sensor's motion since
  // the last frame from other sensors (wheel speed + gyro); replaces the constant-velocity
  // prediction, which lags a whole frame at a turn's onset.
  // buffers: scratch for this call (large: static storage).
  OdometryResult register_frame(std::span<const Vec3f> scan, OdometryScanBuffers& buffers,
                                const Pose3d* predicted_delta = nullptr);
  // The same for a scan already voxelised at 0.5 v in the sensor frame (the localizer's ingest
  // does it once for odometry and registration): skips the range filter's copy and the fine pass.
  OdometryResult register_voxelized_frame(std::span<const Vec3f> fine, const Pose3d* predicted_delta = nullptr);

  // The arithmetic stays on the 4x4 (pose_types.hpp); these label the same 16 doubles.
  Pose3d pose() const { return Pose3d(pose_); }
  Pose3d last_delta() const { return Pose3d(delta_); }
  std::span<const MapPoint> map_points() const { return map_.points(); }
  std::size_t map_voxel_count() const { return map_.voxel_count(); }
  const OdometryParams& params() const { return params_; }

 private:
  void keep_in_range(std::span<const Vec3f> points, BoundedVector<Vec3f>& out, OdometryResult& r) const;
  OdometryResult register_fine(const Mat4d* predicted_delta, OdometryResult& r);
  OdometryResult finish_frame(OdometryResult& r) const;
  void update_threshold(OdometryResult& r);
  void build_coarse_frame(OdometryResult& r);
  std::uint32_t find_coarse(const std::int32_t key[3]) const;
  // The normal of coarse voxel `self` (its fine points' mean `mean`; coarse edge cv).
  Vec3f coarse_normal(std::uint32_t self, const Vec3d& mean, double cv) const;
  Mat4d align(const Mat4d& prediction, OdometryResult& r);
  void thin_fine_frame(OdometryResult& r);
  double model_sigma() const;

  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  OdometryParams params_;
  Mat4d pose_ = Mat4d::Identity();
  Mat4d delta_ = Mat4d::Identity();
  Mat4d last_deviation_ = Mat4d::Identity();
  bool first_frame_ = true;
  double deviation_sse_ = 0.0;
  std::uint64_t deviation_samples_ = 0;

  OdometryVoxelMap map_;  // the local map (odometry_map.hpp)

  // Per-frame buffers.
  FixedVector<Vec3f, config::kMaxDownsampledPoints> frame_fine_;
  FixedVector<Vec3f, config::kMaxDownsampledPoints> frame_coarse_;
  // 1.5 v voxels of this frame with the moments of their fine points (source normals).
  struct CoarseVoxel {
    std::int32_t key[3] = {0, 0, 0};
    std::uint32_t count = 0;
    std::uint32_t slot = 0;
    Vec3d sum = Vec3d::Zero();
    double outer[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};  // sum of p p^T: xx, xy, xz, yy, yz, zz
  };
  static constexpr std::size_t kMaxCoarse = config::kMaxDownsampledPoints;
  static constexpr std::size_t kCoarseSlots = 2 * config::kMaxDownsampledPoints;
  static_assert((kCoarseSlots & (kCoarseSlots - 1)) == 0, "hash slots must be a power of two");
  CoarseVoxel coarse_[kMaxCoarse];
  std::uint32_t coarse_slots_[kCoarseSlots] = {};  // coarse voxel index + 1, 0 = empty
  Vec3f coarse_normals_[config::kMaxDownsampledPoints];
  // Per registration point: its last query's voxel block (align(): the map is fixed meanwhile).
  OdometryVoxelMap::NeighborBlock blocks_[config::kMaxDownsampledPoints];
};

}  // namespace v2xloc
