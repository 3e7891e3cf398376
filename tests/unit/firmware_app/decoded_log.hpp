// Records what the decoder returns, input by input (test helper for the decoder tests): the
// decoder itself never calls a localizer, so the tests look at its typed results.
#pragma once

#include <vector>

#include "firmware/wire/input_decoder.hpp"

namespace v2xloc::firmware::test {

struct DecodedLog {
  // Decodes one CAN frame and keeps the vehicle / GNSS input it yields.
  CanInputKind can(InputDecoder& decoder, const hal::CanFrame& frame, std::int64_t time_ns) {
    const DecodedCan d = decoder.decode_can(frame, time_ns);
    if (d.kind == CanInputKind::kVehicle) vehicle.push_back(d.vehicle);
    if (d.kind == CanInputKind::kGnssFix) gnss.push_back(d.gnss);
    return d.kind;
  }
  // Takes the completed cloud (if any) and copies its points out of the decoder's buffers.
  CloudKind cloud(InputDecoder& decoder) {
    const DecodedCloud d = decoder.decode_completed();
    if (d.kind == CloudKind::kMapCloud) {
      map.push_back(d.map);
      map_points.emplace_back(d.map.points.begin(), d.map.points.end());
    }
    if (d.kind == CloudKind::kEgoScan) {
      ego.push_back(d.ego);
      ego_points.emplace_back(d.ego.points.begin(), d.ego.points.end());
      ego_times.emplace_back(d.ego.point_times.begin(), d.ego.point_times.end());
      ego_frame_index.push_back(d.frame_index);
      ego_gnss_used.push_back(d.gnss_used);
    }
    return d.kind;
  }
  std::vector<VehicleInput> vehicle;
  std::vector<GnssInput> gnss;
  std::vector<MapCloudInput> map;
  std::vector<std::vector<Vec3f>> map_points;
  std::vector<EgoScanInput> ego;
  std::vector<std::vector<Vec3f>> ego_points;
  std::vector<std::vector<float>> ego_times;
  std::vector<std::uint32_t> ego_frame_index;
  std::vector<bool> ego_gnss_used;
};

}  // namespace v2xloc::firmware::test
