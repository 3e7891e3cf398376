// Every capacity and iteration cap of the core, in one place. Static memory follows from these
// (v2xloc-info prints it). Two profiles: the default (Linux ECU / host) and EMBEDDED (a bare-metal
// Cortex-R target with a few MB of RAM), selected with -DV2XLOC_PROFILE_EMBEDDED.
// Sections are owned by the stage that uses them; add a constant next to its siblings, with a
// unit and a reason.
#pragma once

#include <cstddef>
#include <cstdint>

namespace v2xloc::config {

#if defined(V2XLOC_PROFILE_EMBEDDED)
inline constexpr bool kEmbeddedProfile = true;
#else
inline constexpr bool kEmbeddedProfile = false;
#endif

// ---- Point clouds -------------------------------------------------------------------------
// A 64-beam, 1800-step sweep has <= 115200 returns; a 32-beam infrastructure unit fewer.
// EMBEDDED holds a 64-beam sweep of ~64k returns whole (16 B a point in the receive buffer):
// thinned evenly to 16,384 it left the start-up search the street's look-alikes (algo/TUNING.md,
// "EMBEDDED: whole sweeps"). More points arrive evenly thinned (counted).
inline constexpr std::size_t kMaxScanPoints = kEmbeddedProfile ? 65536 : 131072;
// After voxel downsampling (registration works on these).
inline constexpr std::size_t kMaxDownsampledPoints = kEmbeddedProfile ? 4096 : 32768;
// Ego stereo cloud (subsampled disparity pixels kept within the depth-noise limit).
inline constexpr std::size_t kMaxStereoPoints = kEmbeddedProfile ? 4096 : 65536;
// Reference map (fused infrastructure + agent clouds, downsampled).
// EMBEDDED 12,288: its start-up and valid registrations follow the map's density (algo/TUNING.md).
inline constexpr std::size_t kMaxMapPoints = kEmbeddedProfile ? 12288 : 131072;
// A map cloud's points staged for fusion (MapFusionParams::max_input_points reads a bigger cloud
// with an even stride down to its limit, 16,384 by default; this caps it). A 32-beam unit's
// cloud holds ~16k points; EMBEDDED keeps no room for more (12 B a point).
inline constexpr std::size_t kMaxMapInputPoints = kEmbeddedProfile ? 16384 : kMaxScanPoints;

// ---- Voxel downsampling ---------------------------------------------------------------------
// Open-addressing slots; a power of two, >= 2x the point capacity keeps probe chains short.
inline constexpr std::size_t kVoxelHashSlots = kEmbeddedProfile ? 32768 : 262144;
inline constexpr std::size_t kVoxelMaxProbes = 64;  // every voxel-key hash (core/spatial_hash.hpp): probes; beyond -> counted drop

// ---- k-d tree -------------------------------------------------------------------------------
inline constexpr std::size_t kKdLeafSize = 8;           // points per leaf
inline constexpr std::size_t kKdFeatureLeafSize = 32;   // 33-D FPFH trees: big leaves (measured)
inline constexpr std::size_t kKdMaxDepth = 48;          // traversal stack depth (log2(N)+slack)
inline constexpr std::size_t kKdMaxNodeVisits = 4096;   // per query; bounded worst case
inline constexpr std::size_t kMaxNeighbors = 128;       // kNN / hybrid result buffers

// ---- Proximity grid -------------------------------------------------------------------------
// Pose-search hypothesis scoring asks "a map point within reach?" of a bitmap, one bit per cell
// (search/proximity_grid.hpp); rows of 64-bit words. 2^21 cells = 256 KiB: a 220 x 220 x 40 m
// box (+ reach margin) at 1.125 m cells. Bigger boxes get bigger cells, not an overflow.
inline constexpr std::size_t kProximityGridWords = kEmbeddedProfile ? 8192 : 32768;  // 64-bit words (host 256 KiB, embedded 64 KiB)

// ---- Normals / FPFH -------------------------------------------------------------------------
inline constexpr std::size_t kNormalMaxNeighbors = 30;  // Open3D's KDTreeSearchParamHybrid default
inline constexpr std::size_t kFpfhMaxNeighbors = 100;   // Open3D examples: radius 5 voxels, 100 nn
inline constexpr std::uint32_t kJacobiMaxSweeps = 16;   // 3x3 symmetric eigen; converges in <= ~6
// Neighbour lists shared by normals and both FPFH passes (one search per point, 16-bit indices,
// 2 B each): ~50-entry lists (outdoor LiDAR, FPFH radius 5 voxels) of ~20k points. Points beyond
// are searched again (same result, slower; counted). Embedded: none (RAM over speed; every list
// is searched per stage as before).
inline constexpr std::size_t kNeighborhoodCacheEntries = kEmbeddedProfile ? 0 : 1048576;

// ---- Correspondences / RANSAC ---------------------------------------------------------------
inline constexpr std::size_t kMaxCorrespondences = kMaxDownsampledPoints;
inline constexpr std::uint32_t kRansacMaxIterations = 100000;   // hard cap (Open3D default)
inline constexpr std::uint32_t kRansacMaxValidations = 1000;    // full inlier counts per run

// ---- ICP ------------------------------------------------------------------------------------
inline constexpr std::uint32_t kIcpMaxIterations = 64;
// Pose search (start-up, lost track, basin audit): scan points its hypotheses are refined and
// compared on, a uniform subsample of the registration scan. Its ICPs are 2 x 10 candidates x
// <= 30 iterations: this caps their nearest-neighbour queries at ~1.2 M per search whatever the
// scan size (ScanPreparationParams::search_points picks the number, <= this).
inline constexpr std::size_t kMaxSearchPoints = 2048;

// ---- Localization ---------------------------------------------------------------------------
inline constexpr std::size_t kGateMaxWindow = 64;          // validity-gate window w (frames)
inline constexpr std::size_t kEkfHistoryLength = 32;       // fixed-lag history (frames)
// Output frames held for revision once the filter starts (trajectory_backfill.hpp): start-up
// takes 1-2 s on the recordings, 6.4 s covers a slow one; ~17 kB.
inline constexpr std::size_t kBackfillFrames = 64;
inline constexpr std::size_t kOdometryMapPoints = kEmbeddedProfile ? 16384 : 131072;
inline constexpr std::size_t kMaxMapSources = 16;          // infra units + agents tracked at once
// EKF: events (measurements + frame markers) kept for out-of-sequence replay; ~16 per frame
// (100 Hz vehicle signals at 10 Hz frames, GNSS, registration, odometry).
inline constexpr std::size_t kEkfEventLogCapacity = kEkfHistoryLength * 16;
inline constexpr std::uint32_t kEkfMaxPredictSubsteps = 100;   // per prediction segment
// Odometry local map: voxel hash slots (power of two, >= 2x the voxels), points per voxel
// (KISS-ICP uses 20), ICP Gauss-Newton iterations (KISS-ICP: 500 cap, usually < 10 used).
inline constexpr std::size_t kOdometryHashSlots = kEmbeddedProfile ? 16384 : 131072;
inline constexpr std::size_t kOdometryMaxPointsPerVoxel = 20;
inline constexpr std::uint32_t kOdometryMaxIterations = 50;
// Map fusion: voxel hash slots for merging clouds (power of two, >= 2x points; EMBEDDED 4/3x, its RAM).
inline constexpr std::size_t kMapConsistencyPoints = 4096;  // candidate points a consistency check samples
inline constexpr std::size_t kMapFusionHashSlots = kEmbeddedProfile ? 16384 : 262144;
// Map fusion's consistency reference (localization/source_cells.hpp): cells of the surveyed
// sources' points on three grids, ~1.9-2.5 cells per point (measured, four units), rebuilt once live
// and emptied cells fill this many quarters of the slots (source_cells.hpp). 17 B each (a cell and
// its byte of the seen bitmap).
inline constexpr std::size_t kMapReferenceCellSlots = kEmbeddedProfile ? 65536 : 262144;
inline constexpr std::size_t kMapReferenceCellRebuildQuarters = kEmbeddedProfile ? 3 : 2;
// Surveyed backgrounds (localization/surveyed_background.hpp): infrastructure units that have one,
// and its cells (4 B packed keys in the firmware's static storage: kMaxBackgroundUnits x
// kMaxBackgroundCells x 4 B, EMBEDDED 4 x 8,192 x 4 B = 128 KiB). A 32-beam unit's static scene
// has ~14k cells at 0.2 m and ~7.6-8k at 0.52 m; the simulator grows the cell until a background
// fits kBackgroundFileCells, so every profile loads the same file.
inline constexpr std::size_t kMaxBackgroundUnits = kEmbeddedProfile ? 4 : 8;
inline constexpr std::size_t kMaxBackgroundCells = kEmbeddedProfile ? 8192 : 32768;
inline constexpr std::size_t kBackgroundFileCells = 8192;
static_assert(kBackgroundFileCells <= kMaxBackgroundCells, "the simulator's backgrounds fit every profile");
// Cloud points one background check scores (even stride over the cloud): a fraction from 1k
// samples is pinned to ~1 % (1 sigma at 0.9), well inside the 0.1 gap between the genuine and
// the moved clouds' scores (algo/TUNING.md).
inline constexpr std::size_t kBackgroundCheckPoints = 1024;

// ---- Geodesy --------------------------------------------------------------------------------
// Bowring's ECEF->geodetic iteration converges to 1e-14 rad in 2-3 steps for |h| < 1e5 m.
inline constexpr std::uint32_t kGeodesyMaxIterations = 8;

}  // namespace v2xloc::config
