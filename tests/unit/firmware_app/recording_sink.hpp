// A LocalizerPort that records what reaches it (test double for the decoder tests).
#pragma once

#include <vector>

#include "firmware/app/localizer_port.hpp"

namespace v2xloc::firmware::test {

class RecordingSink final : public LocalizerPort {
 public:
  void on_vehicle(const VehicleInput& in) override { vehicle.push_back(in); }
  void on_gnss(const GnssInput& in) override { gnss.push_back(in); }
  MapInsertResult on_map_cloud(const MapCloudInput& in) override {
    map.push_back(in);
    map_points.push_back(std::vector<Vec3f>(in.points.begin(), in.points.end()));
    return MapInsertResult{};
  }
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& in) override {
    ego.push_back(in);
    ego_points.push_back(std::vector<Vec3f>(in.points.begin(), in.points.end()));
    ego_times.push_back(std::vector<float>(in.point_times.begin(), in.point_times.end()));
    out.frame = static_cast<std::uint32_t>(ego.size() - 1);
    out.t = in.t;
    return out;
  }
  std::vector<VehicleInput> vehicle;
  std::vector<GnssInput> gnss;
  std::vector<MapCloudInput> map;
  std::vector<std::vector<Vec3f>> map_points;
  std::vector<EgoScanInput> ego;
  std::vector<std::vector<Vec3f>> ego_points;
  std::vector<std::vector<float>> ego_times;
  LocalizerFrameOutput out;
};

}  // namespace v2xloc::firmware::test
