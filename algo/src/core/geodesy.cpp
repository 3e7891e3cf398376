#include "v2xloc/algo/core/geodesy.hpp"

#include <cmath>

#include "v2xloc/algo/core/det_math.hpp"
#include "v2xloc/algo/core/finite.hpp"

namespace v2xloc {
namespace {

constexpr double kDegToRad = det::kPi / 180.0;
constexpr double kRadToDeg = 180.0 / det::kPi;


}  // namespace

Vec3d geodetic_to_ecef(const GeodeticPoint& p) {
  const double lat = p.lat_deg * kDegToRad, lon = p.lon_deg * kDegToRad;
  const double sin_lat = det::sin(lat), cos_lat = det::cos(lat);
  const double sin_lon = det::sin(lon), cos_lon = det::cos(lon);
  // Prime-vertical radius of curvature N = a / sqrt(1 - e^2 sin^2(lat)).
  const double n = wgs84::kSemiMajorAxis / std::sqrt(1.0 - wgs84::kEccentricitySq * sin_lat * sin_lat);
  return {(n + p.alt_m) * cos_lat * cos_lon, (n + p.alt_m) * cos_lat * sin_lon,
          (n * (1.0 - wgs84::kEccentricitySq) + p.alt_m) * sin_lat};
}

GeodeticOrigin make_geodetic_origin(double lat_deg, double lon_deg, double alt_m) {
  GeodeticOrigin o;
  o.geodetic = {lat_deg, lon_deg, alt_m};
  o.ecef = geodetic_to_ecef(o.geodetic);
  const double lat = lat_deg * kDegToRad, lon = lon_deg * kDegToRad;
  const double sl = det::sin(lat), cl = det::cos(lat), so = det::sin(lon), co = det::cos(lon);
  o.enu_from_ecef << -so, co, 0.0,            //
      -sl * co, -sl * so, cl,                 //
      cl * co, cl * so, sl;
  return o;
}

EcefToGeodeticResult ecef_to_geodetic(const Vec3d& ecef, const EcefToGeodeticCriteria& criteria) {
  EcefToGeodeticResult r;
  if (!is_finite_point(ecef)) return r;
  const double x = ecef.x(), y = ecef.y(), z = ecef.z();
  const double p = std::sqrt(x * x + y * y);
  if (p == 0.0 && z == 0.0) return r;  // the centre has no geodetic coordinates

  constexpr double a = wgs84::kSemiMajorAxis, b = wgs84::kSemiMinorAxis;
  constexpr double e2 = wgs84::kEccentricitySq, ep2 = wgs84::kSecondEccentricitySq;
  constexpr double one_minus_f = 1.0 - wgs84::kFlattening;

  // Bowring: start from the parametric latitude of the point's direction, then alternate
  //   tan(lat) = (z + e'^2 b sin^3 beta) / (p - e^2 a cos^3 beta),  tan(beta) = (1 - f) tan(lat).
  // Sines and cosines are carried as normalized pairs, so the loop needs no atan.
  double sb = z, cb = one_minus_f * p;
  double norm = std::sqrt(sb * sb + cb * cb);
  sb /= norm;
  cb /= norm;
  double sin_lat = 0.0, cos_lat = 1.0, num = z, den = p;
  const std::uint32_t cap = criteria.max_iterations == 0 ? 1 : criteria.max_iterations;
  r.status = GeodesyStatus::kIterationCap;
  for (std::uint32_t it = 0; it < cap; ++it) {
    num = z + ep2 * b * sb * sb * sb;
    den = p - e2 * a * cb * cb * cb;
    norm = std::sqrt(num * num + den * den);
    const double s_new = num / norm, c_new = den / norm;
    // |sin(lat_new - lat_old)| measures the update.
    const double change = std::abs(s_new * cos_lat - c_new * sin_lat);
    sin_lat = s_new;
    cos_lat = c_new;
    r.iterations = it + 1;
    sb = one_minus_f * sin_lat;
    cb = cos_lat;
    norm = std::sqrt(sb * sb + cb * cb);
    sb /= norm;
    cb /= norm;
    if (it > 0 && change <= criteria.latitude_tolerance_rad) {
      r.status = GeodesyStatus::kConverged;
      break;
    }
  }
  r.point.lat_deg = det::atan2(num, den) * kRadToDeg;
  double lon = (p == 0.0) ? 0.0 : det::atan2(y, x);
  if (lon <= -det::kPi) lon += 2.0 * det::kPi;
  r.point.lon_deg = lon * kRadToDeg;
  // h = p cos(lat) + z sin(lat) - a^2 / N: well conditioned at every latitude, poles included.
  r.point.alt_m = p * cos_lat + z * sin_lat - a * std::sqrt(1.0 - e2 * sin_lat * sin_lat);
  return r;
}

Vec3d ecef_delta_to_enu(const GeodeticOrigin& origin, const Vec3d& delta_ecef) {
  return origin.enu_from_ecef * delta_ecef;
}

Vec3d ecef_to_enu(const GeodeticOrigin& origin, const Vec3d& ecef) {
  return origin.enu_from_ecef * (ecef - origin.ecef);
}

Vec3d enu_to_ecef(const GeodeticOrigin& origin, const Vec3d& enu) {
  return origin.ecef + origin.enu_from_ecef.transpose() * enu;
}

Vec3d geodetic_to_enu(const GeodeticOrigin& origin, const GeodeticPoint& p) {
  return ecef_to_enu(origin, geodetic_to_ecef(p));
}

EcefToGeodeticResult enu_to_geodetic(const GeodeticOrigin& origin, const Vec3d& enu,
                                     const EcefToGeodeticCriteria& criteria) {
  return ecef_to_geodetic(enu_to_ecef(origin, enu), criteria);
}

}  // namespace v2xloc
