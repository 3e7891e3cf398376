// Writes a target fixture (firmware/fixture/fixture_format.hpp) on the host: the recording tool
// below taps the offline wire path (host_sim/replay/event_stream.hpp) with it, the worst-case
// suite writes its drive with it. A cloud over the fixture's capacity (what the firmware's
// reassembler delivers) keeps its first points and is counted.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

#include "host_sim/replay/event_stream.hpp"
#include "v2xloc/algo/localization/localizer_types.hpp"

namespace v2xloc::fixture {

class FixtureWriter final : public sim::replay::LocalizerInputTap {
 public:
  FixtureWriter() = default;
  FixtureWriter(const FixtureWriter&) = delete;
  FixtureWriter& operator=(const FixtureWriter&) = delete;
  ~FixtureWriter() { close(); }

  bool open(const std::string& path);
  // Ends the fixture (kEnd); false if any write failed.
  bool close();

  void configure(double lat_deg, double lon_deg, double alt_m);
  void label(const std::string& name);
  void vehicle(const VehicleInput& input) override;
  void gnss(const GnssInput& input) override;
  void imu(const ImuInput& input) override;
  void map_cloud(const MapCloudInput& input) override;
  void period_work(double instructions) override;
  void ego_scan(const EgoScanInput& input) override;

  std::uint64_t clouds_clipped() const { return clouds_clipped_; }
  std::uint64_t periods() const { return periods_; }

 private:
  template <class T>
  void put(const T& v) {
    ok_ = ok_ && std::fwrite(&v, sizeof v, 1, f_) == 1;
  }
  void put_pose(const Pose3d& pose);
  void put_points(std::span<const Vec3f> points);

  std::FILE* f_ = nullptr;
  bool ok_ = false;
  std::uint64_t clouds_clipped_ = 0, periods_ = 0;
};

}  // namespace v2xloc::fixture
