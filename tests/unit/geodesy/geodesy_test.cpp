#include "v2xloc/algo/core/geodesy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace v2xloc {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Independent reference: Heikkinen's closed form (1982) with libm, as in Zhu (1994).
GeodeticPoint heikkinen(const Vec3d& e) {
  const double a = wgs84::kSemiMajorAxis, b = wgs84::kSemiMinorAxis;
  const double e2 = wgs84::kEccentricitySq, ep2 = wgs84::kSecondEccentricitySq;
  const double r = std::hypot(e.x(), e.y());
  const double F = 54.0 * b * b * e.z() * e.z();
  const double G = r * r + (1 - e2) * e.z() * e.z() - e2 * (a * a - b * b);
  const double c = e2 * e2 * F * r * r / (G * G * G);
  const double s = std::cbrt(1 + c + std::sqrt(c * c + 2 * c));
  const double P = F / (3 * (s + 1 / s + 1) * (s + 1 / s + 1) * G * G);
  const double Q = std::sqrt(1 + 2 * e2 * e2 * P);
  const double r0 = -(P * e2 * r) / (1 + Q) +
                    std::sqrt(0.5 * a * a * (1 + 1 / Q) - P * (1 - e2) * e.z() * e.z() / (Q * (1 + Q)) -
                              0.5 * P * r * r);
  const double U = std::hypot(r - e2 * r0, e.z());
  const double V = std::sqrt((r - e2 * r0) * (r - e2 * r0) + (1 - e2) * e.z() * e.z());
  const double z0 = b * b * e.z() / (a * V);
  GeodeticPoint g;
  g.alt_m = U * (1 - b * b / (a * V));
  g.lat_deg = std::atan((e.z() + ep2 * z0) / r) * 180.0 / kPi;
  g.lon_deg = std::atan2(e.y(), e.x()) * 180.0 / kPi;
  return g;
}

TEST(Geodesy, KnownPoints) {
  const Vec3d equator = geodetic_to_ecef({0.0, 0.0, 0.0});
  EXPECT_NEAR(equator.x(), wgs84::kSemiMajorAxis, 1e-9);
  EXPECT_NEAR(equator.y(), 0.0, 1e-9);
  EXPECT_NEAR(equator.z(), 0.0, 1e-9);
  const Vec3d pole = geodetic_to_ecef({90.0, 0.0, 100.0});
  EXPECT_NEAR(pole.x(), 0.0, 1e-6);
  EXPECT_NEAR(pole.z(), wgs84::kSemiMinorAxis + 100.0, 1e-6);
  const auto g = ecef_to_geodetic(pole);
  EXPECT_NEAR(g.point.lat_deg, 90.0, 1e-9);
  EXPECT_NEAR(g.point.alt_m, 100.0, 1e-6);
  // East at lon 90: ECEF +y.
  const Vec3d east = geodetic_to_ecef({0.0, 90.0, 0.0});
  EXPECT_NEAR(east.y(), wgs84::kSemiMajorAxis, 1e-6);
}

TEST(Geodesy, RoundTripGridSubMillimetre) {
  int worst_iterations = 0;
  double worst_pos = 0.0, worst_deg = 0.0;
  for (double lat = -89.95; lat <= 90.0; lat += 3.7) {
    for (double lon = -179.9; lon <= 180.0; lon += 7.3) {
      for (double alt : {-430.0, 0.0, 520.3, 8848.0, 35000.0}) {
        const GeodeticPoint p{lat, lon, alt};
        const Vec3d ecef = geodetic_to_ecef(p);
        const auto r = ecef_to_geodetic(ecef);
        ASSERT_EQ(r.status, GeodesyStatus::kConverged) << lat << " " << lon << " " << alt;
        worst_iterations = std::max<int>(worst_iterations, static_cast<int>(r.iterations));
        worst_deg = std::max({worst_deg, std::abs(r.point.lat_deg - lat), std::abs(r.point.lon_deg - lon)});
        worst_pos = std::max(worst_pos, (geodetic_to_ecef(r.point) - ecef).norm());
        EXPECT_NEAR(r.point.alt_m, alt, 1e-3);
        // Agrees with the independent closed form.
        const GeodeticPoint h = heikkinen(ecef);
        EXPECT_NEAR(r.point.lat_deg, h.lat_deg, 1e-9);
        EXPECT_NEAR(r.point.alt_m, h.alt_m, 1e-3);
      }
    }
  }
  EXPECT_LT(worst_deg, 1e-9);
  EXPECT_LT(worst_pos, 1e-3);
  EXPECT_LE(worst_iterations, 4);
}

TEST(Geodesy, SatelliteAltitudeConverges) {
  const GeodeticPoint p{37.2, -121.9, 20.2e6};
  const auto r = ecef_to_geodetic(geodetic_to_ecef(p));
  EXPECT_EQ(r.status, GeodesyStatus::kConverged);
  EXPECT_NEAR(r.point.lat_deg, p.lat_deg, 1e-9);
  EXPECT_NEAR(r.point.alt_m, p.alt_m, 1e-3);
}

TEST(Geodesy, EnuFrameAndRoundTrip) {
  const GeodeticOrigin o = make_geodetic_origin(48.137154, 11.576124, 519.0);  // Munich
  // The origin maps to zero, a point straight up to +z.
  EXPECT_LT(geodetic_to_enu(o, o.geodetic).norm(), 1e-6);
  const Vec3d up = geodetic_to_enu(o, {48.137154, 11.576124, 619.0});
  EXPECT_NEAR(up.z(), 100.0, 1e-6);
  EXPECT_NEAR(up.head<2>().norm(), 0.0, 1e-6);
  // A small step north / east.
  const Vec3d north = geodetic_to_enu(o, {48.138154, 11.576124, 519.0});
  EXPECT_GT(north.y(), 110.0);
  EXPECT_LT(north.y(), 112.0);
  EXPECT_NEAR(north.x(), 0.0, 1e-6);
  const Vec3d east = geodetic_to_enu(o, {48.137154, 11.577124, 519.0});
  // East step = N cos(lat) dlon (N: prime-vertical radius), to first order.
  const double lat = 48.137154 * kPi / 180.0;
  const double n = wgs84::kSemiMajorAxis / std::sqrt(1.0 - wgs84::kEccentricitySq * std::sin(lat) * std::sin(lat));
  EXPECT_NEAR(east.x(), (n + 519.0) * std::cos(lat) * 0.001 * kPi / 180.0, 0.01);
  // Rotation is orthonormal.
  EXPECT_LT((o.enu_from_ecef * o.enu_from_ecef.transpose() - Mat3d::Identity()).norm(), 1e-14);
  for (double x = -2000.0; x <= 2000.0; x += 250.0) {
    for (double y = -2000.0; y <= 2000.0; y += 330.0) {
      for (double z : {-20.0, 1.8, 45.0}) {
        const Vec3d enu(x, y, z);
        const auto g = enu_to_geodetic(o, enu);
        ASSERT_EQ(g.status, GeodesyStatus::kConverged);
        EXPECT_LT((geodetic_to_enu(o, g.point) - enu).norm(), 1e-3);
      }
    }
  }
}

TEST(Geodesy, InvalidInputFlagged) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ecef_to_geodetic(Vec3d(nan, 0, 0)).status, GeodesyStatus::kInvalidInput);
  EXPECT_EQ(ecef_to_geodetic(Vec3d::Zero()).status, GeodesyStatus::kInvalidInput);
  EcefToGeodeticCriteria one_step;
  one_step.max_iterations = 1;
  const auto r = ecef_to_geodetic(geodetic_to_ecef({45.0, 10.0, 100.0}), one_step);
  EXPECT_EQ(r.status, GeodesyStatus::kIterationCap);
  EXPECT_EQ(r.iterations, 1u);
  EXPECT_NEAR(r.point.alt_m, 100.0, 1e-2);  // Bowring's single step is already close
}

}  // namespace
}  // namespace v2xloc
