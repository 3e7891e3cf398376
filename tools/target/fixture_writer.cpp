#include "tools/target/fixture_writer.hpp"

#include <algorithm>

#include "firmware/fixture/fixture_format.hpp"

namespace v2xloc::fixture {

bool FixtureWriter::open(const std::string& path) {
  close();
  f_ = std::fopen(path.c_str(), "wb");
  ok_ = f_ != nullptr;
  put(kMagic);
  put(kVersion);
  return ok_;
}

bool FixtureWriter::close() {
  if (f_ == nullptr) return ok_;
  put(Tag::kEnd);
  ok_ = std::fclose(f_) == 0 && ok_;
  f_ = nullptr;
  return ok_;
}

void FixtureWriter::put_pose(const Pose3d& pose) {
  for (int i = 0; i < 16; ++i) put(pose.matrix().data()[i]);
}

void FixtureWriter::put_points(std::span<const Vec3f> points) {
  const std::size_t n = std::min(points.size(), kMaxPoints);
  if (n < points.size()) ++clouds_clipped_;
  put(static_cast<std::uint32_t>(n));
  if (n > 0) ok_ = ok_ && std::fwrite(points.data(), sizeof(Vec3f), n, f_) == n;
}

void FixtureWriter::configure(double lat_deg, double lon_deg, double alt_m) {
  put(Tag::kConfigure);
  put(lat_deg);
  put(lon_deg);
  put(alt_m);
}

void FixtureWriter::label(const std::string& name) {
  const std::size_t n = std::min(name.size(), kMaxLabel);
  put(Tag::kLabel);
  put(static_cast<std::uint8_t>(n));
  if (n > 0) ok_ = ok_ && std::fwrite(name.data(), 1, n, f_) == n;
}

void FixtureWriter::vehicle(const VehicleInput& v) {
  put(Tag::kVehicle);
  put(v.t);
  put(v.wheel_speed);
  put(v.yaw_rate);
}

void FixtureWriter::gnss(const GnssInput& g) {
  put(Tag::kGnss);
  put(g.t);
  put(g.lat_deg);
  put(g.lon_deg);
  put(g.alt_m);
  put(g.h_acc);
  put(g.v_acc);
  put(g.num_sats);
  put(g.hdop);
  put(static_cast<std::uint8_t>(g.valid ? 1 : 0));
  put(static_cast<std::uint8_t>(g.velocity_valid ? 1 : 0));
  put(g.vel_east);
  put(g.vel_north);
  put(g.speed_acc);
}

void FixtureWriter::imu(const ImuInput& input) {
  put(Tag::kImu);
  put(input.t);
  for (const double g : input.gyro) put(g);
  for (const double a : input.accel) put(a);
  put(static_cast<std::uint8_t>(input.saturated ? 1 : 0));
}

void FixtureWriter::map_cloud(const MapCloudInput& m) {
  put(Tag::kMapCloud);
  put(m.source_id);
  put(static_cast<std::uint8_t>(m.is_agent ? 1 : 0));
  put(m.t);
  put_pose(m.world_T_sensor);
  put_points(m.points);
}

void FixtureWriter::period_work(double instructions) {
  put(Tag::kPeriodWork);
  put(instructions);
}

void FixtureWriter::ego_scan(const EgoScanInput& e) {
  put(Tag::kEgoScan);
  put(e.t);
  put_pose(e.body_T_lidar);
  put_points(e.points);
  const std::size_t n = std::min(e.points.size(), kMaxPoints);
  const std::size_t m = e.point_times.size() == e.points.size() ? n : 0;
  put(static_cast<std::uint32_t>(m));
  if (m > 0) ok_ = ok_ && std::fwrite(e.point_times.data(), sizeof(float), m, f_) == m;
  ++periods_;
}

}  // namespace v2xloc::fixture
