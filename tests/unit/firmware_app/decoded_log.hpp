// Records what the decoders return, input by input (test helper for the decoder tests): the
// decoders never call a localizer, so the tests look at their typed results.
#pragma once

#include <vector>

#include "firmware/wire/input_decoder.hpp"

namespace v2xloc::firmware::test {

struct DecodedLog {
  // Decodes one CAN frame and keeps the vehicle / GNSS input it yields.
  CanInputKind can(CanInputDecoder& decoder, const hal::CanFrame& frame, std::int64_t time_ns) {
    const DecodedCan d = decoder.decode(frame, time_ns);
    if (d.kind == CanInputKind::kVehicle) vehicle.push_back(d.vehicle);
    if (d.kind == CanInputKind::kGnssFix) gnss.push_back(d.gnss);
    return d.kind;
  }
  // Takes the completed cloud (if any) from the whole decoder and copies its points out of the
  // decoder's buffers. A queued share is verified at once (these tests look at decoding, not at
  // the verification budget).
  CloudKind cloud(InputDecoder& decoder) {
    DecodedCloud d = decoder.decode_completed();
    if (d.kind == CloudKind::kMapQueued) {
      decoder.shares().begin_period(decoder.clouds().completed_local_time_ns());
      d = decoder.next_verified_share();
    }
    return record(d);
  }
  // The same from the cloud reassembly alone (a map share comes back as kMapShare).
  CloudKind cloud(CloudInputDecoder& decoder) { return record(decoder.decode_completed()); }

  std::vector<VehicleInput> vehicle;
  std::vector<GnssInput> gnss;
  std::vector<MapCloudInput> map;
  std::vector<std::vector<Vec3f>> map_points;
  std::vector<EgoScanInput> ego;
  std::vector<std::vector<Vec3f>> ego_points;
  std::vector<std::vector<float>> ego_times;
  std::vector<std::uint32_t> ego_frame_index;
  std::vector<bool> ego_gnss_used;

 private:
  CloudKind record(const DecodedCloud& d) {
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
};

}  // namespace v2xloc::firmware::test
