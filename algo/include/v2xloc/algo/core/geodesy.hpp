// WGS84 geodetic <-> ECEF <-> local ENU. Deterministic (det_math only, no libm transcendentals),
// allocation-free, double precision. ECEF -> geodetic uses Bowring's parametric-latitude
// iteration (Bowring 1976; one step is already sub-mm for terrestrial heights) with a hard cap.
#pragma once

#include <cstdint>

#include "v2xloc/algo/core/config.hpp"
#include "v2xloc/algo/core/types.hpp"

namespace v2xloc {

namespace wgs84 {
inline constexpr double kSemiMajorAxis = 6378137.0;              // a [m]
inline constexpr double kFlattening = 1.0 / 298.257223563;       // f
inline constexpr double kSemiMinorAxis = kSemiMajorAxis * (1.0 - kFlattening);  // b [m]
inline constexpr double kEccentricitySq = kFlattening * (2.0 - kFlattening);    // e^2
// Second eccentricity squared e'^2 = e^2 / (1 - e^2).
inline constexpr double kSecondEccentricitySq = kEccentricitySq / (1.0 - kEccentricitySq);
}  // namespace wgs84

struct GeodeticPoint {
  double lat_deg = 0.0;
  double lon_deg = 0.0;  // (-180, 180]
  double alt_m = 0.0;    // height above the ellipsoid
};

// The local tangent frame: x east, y north, z up at the origin; built once, reused per point.
struct GeodeticOrigin {
  GeodeticPoint geodetic;
  Vec3d ecef = Vec3d::Zero();
  Mat3d enu_from_ecef = Mat3d::Identity();  // rows: east, north, up unit vectors in ECEF
};

GeodeticOrigin make_geodetic_origin(double lat_deg, double lon_deg, double alt_m);

Vec3d geodetic_to_ecef(const GeodeticPoint& p);

struct EcefToGeodeticCriteria {
  double latitude_tolerance_rad = 1e-14;  // stop once the latitude update is below this
  std::uint32_t max_iterations = config::kGeodesyMaxIterations;
};

enum class GeodesyStatus : std::uint8_t {
  kConverged,
  kIterationCap,    // result usable (error bounded by the last update), but not converged
  kInvalidInput,    // NaN/Inf or the Earth's centre: output zeroed
};

struct EcefToGeodeticResult {
  GeodeticPoint point;
  GeodesyStatus status = GeodesyStatus::kInvalidInput;
  std::uint32_t iterations = 0;
};

EcefToGeodeticResult ecef_to_geodetic(const Vec3d& ecef, const EcefToGeodeticCriteria& criteria = {});

Vec3d ecef_to_enu(const GeodeticOrigin& origin, const Vec3d& ecef);
Vec3d enu_to_ecef(const GeodeticOrigin& origin, const Vec3d& enu);
// Rotates a direction/difference vector only (no translation).
Vec3d ecef_delta_to_enu(const GeodeticOrigin& origin, const Vec3d& delta_ecef);

Vec3d geodetic_to_enu(const GeodeticOrigin& origin, const GeodeticPoint& p);
EcefToGeodeticResult enu_to_geodetic(const GeodeticOrigin& origin, const Vec3d& enu,
                                     const EcefToGeodeticCriteria& criteria = {});

}  // namespace v2xloc
