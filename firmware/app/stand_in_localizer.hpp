// A deliberately simple stand-in with the Localizer API, used only while v2xloc::Localizer is not
// yet part of the build (selected_localizer.hpp picks it then and says so at start-up): dead
// reckoning on wheel speed / yaw rate, reset to each valid GNSS fix, map clouds counted. It lets
// the firmware, the replayer and their bit-identity test run end to end; it does not localize.
#pragma once

#include <cstdint>

#include "v2xloc/algo/det_math.hpp"
#include "v2xloc/algo/geodesy.hpp"
#include "v2xloc/algo/localizer.hpp"
#include "v2xloc/algo/map_fusion.hpp"

namespace v2xloc::firmware {

class StandInLocalizer {
 public:
  void configure(const GeodeticOrigin& origin) {
    origin_ = origin;
    *this = StandInLocalizer{origin};
  }
  void on_vehicle(const VehicleInput& in) {
    if (have_vehicle_) {
      const double dt = in.t - last_vehicle_t_;
      if (dt > 0.0 && dt < 1.0) {
        yaw_ = det::wrap_pi(yaw_ + yaw_rate_ * dt);
        x_ += speed_ * dt * det::cos(yaw_);
        y_ += speed_ * dt * det::sin(yaw_);
        sigma_xy_ += 0.02 * speed_ * dt;
      }
    }
    have_vehicle_ = true;
    last_vehicle_t_ = in.t;
    speed_ = in.wheel_speed;
    yaw_rate_ = in.yaw_rate;
  }
  void on_gnss(const GnssInput& in) {
    if (!in.valid) return;
    const Vec3d enu = geodetic_to_enu(origin_, GeodeticPoint{in.lat_deg, in.lon_deg, in.alt_m});
    x_ = enu.x();
    y_ = enu.y();
    z_ = enu.z() - 1.75;  // antenna height above the body origin in the simulator
    sigma_xy_ = in.h_acc;
    have_fix_ = true;
  }
  MapInsertResult on_map_cloud(const MapCloudInput& in) {
    MapInsertResult r;
    r.status = MapInsertStatus::kInserted;
    r.input_points = static_cast<std::uint32_t>(in.points.size());
    r.stored_points = r.input_points;
    map_points_ += in.points.size();
    return r;
  }
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& in) {
    out_ = LocalizerFrameOutput{};
    out_.frame = frame_++;
    out_.t = in.t;
    out_.mode = have_fix_ ? LocalizationMode::kTracking : LocalizationMode::kUninitialized;
    Mat4d T = Mat4d::Identity();
    const double c = det::cos(yaw_), s = det::sin(yaw_);
    T(0, 0) = c;
    T(0, 1) = -s;
    T(1, 0) = s;
    T(1, 1) = c;
    T(0, 3) = x_;
    T(1, 3) = y_;
    T(2, 3) = z_;
    out_.fused_pose = T;
    out_.odometry_pose = T;
    out_.sigma_x = out_.sigma_y = sigma_xy_;
    out_.sigma_z = 1.0;
    out_.sigma_yaw = 0.05;
    out_.localized = have_fix_ && sigma_xy_ < 0.5;
    return out_;
  }

 private:
  explicit StandInLocalizer(const GeodeticOrigin& origin) : origin_(origin) {}

 public:
  StandInLocalizer() = default;

 private:
  GeodeticOrigin origin_{};
  bool have_vehicle_ = false, have_fix_ = false;
  double last_vehicle_t_ = 0.0, speed_ = 0.0, yaw_rate_ = 0.0;
  double x_ = 0.0, y_ = 0.0, z_ = 0.0, yaw_ = 0.0, sigma_xy_ = 100.0;
  std::uint64_t map_points_ = 0;
  std::uint32_t frame_ = 0;
  LocalizerFrameOutput out_{};
};

}  // namespace v2xloc::firmware
