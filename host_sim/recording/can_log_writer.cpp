#include "host_sim/recording/can_log_writer.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>

#include "firmware/protocol/can_messages.hpp"
#include "host_sim/canlog/candump_log.hpp"

namespace v2xloc::sim {
namespace {

// The manifest's can_log.gnss note: one fix's frames in the order they are sent.
constexpr const char* kGnssFrameOrder =
    "0x130 latitude, 0x130 longitude, 0x131 status, 0x133 velocity, 0x134 DOP, 0x132 time at the GNSS rate";

struct TimedCanFrame {
  std::int64_t us;
  int order;  // tie-break at equal stamps: vehicle motion, then latitude, longitude, status, velocity, DOP, time
  hal::CanFrame frame;
};

void append_vehicle_frames(double time_origin_unix_s, std::span<const VehicleSignals> vehicle,
                           std::vector<TimedCanFrame>& out) {
  for (const VehicleSignals& sig : vehicle) {
    protocol::VehicleMotion vm;
    vm.wheel_speed_mps = sig.wheel_speed_mps;
    vm.yaw_rate_rps = sig.yaw_rate_rps;
    vm.speed_valid = sig.speed_valid;
    vm.yaw_rate_valid = sig.yaw_rate_valid;
    vm.counter = static_cast<std::uint8_t>(sig.counter % protocol::kCounterModulo);
    out.push_back({candump_timestamp_us(time_origin_unix_s + sig.t), 0, protocol::pack(vm)});
  }
}

// GPS week and time of week of a unix time (GPS epoch 1980-01-06, 18 leap seconds since 2017).
protocol::GnssTime gps_time(double unix_t) {
  const double gps_s = unix_t - 315964800.0 + 18.0;
  protocol::GnssTime td;
  td.week = static_cast<std::uint16_t>(std::floor(gps_s / 604800.0));
  td.time_of_week_s = gps_s - 604800.0 * td.week;
  return td;
}

// Each GNSS fix as the CAN layout 2 group: latitude and longitude (valid fixes only), status,
// velocity, DOP and time. The status, velocity, DOP and time counters step once per fix; the
// position id's once per frame (twice per fix).
void append_gnss_frames(double time_origin_unix_s, std::span<const GnssFix> fixes, std::vector<TimedCanFrame>& out) {
  std::uint8_t gnss_counter = 0, position_counter = 0;
  const auto next = [](std::uint8_t& c) {
    const std::uint8_t now = c;
    c = static_cast<std::uint8_t>((c + 1) % protocol::kCounterModulo);
    return now;
  };
  for (const GnssFix& f : fixes) {
    const double unix_t = time_origin_unix_s + f.t;
    const std::int64_t us = candump_timestamp_us(unix_t);
    protocol::GnssStatus status;
    status.alt_m = f.alt_m;
    status.h_acc_m = f.h_acc_m;
    status.v_acc_m = f.v_acc_m;
    status.num_sats = static_cast<std::uint8_t>(std::clamp(f.num_sats, 0, 63));
    status.fix_type = f.valid ? protocol::GnssFixType::kFix3D : protocol::GnssFixType::kNoFix;
    status.counter = next(gnss_counter);
    protocol::GnssVelocity vel;
    vel.vel_east_mps = f.vel_east;
    vel.vel_north_mps = f.vel_north;
    vel.vel_up_mps = f.vel_up;
    vel.speed_acc_mps = f.speed_acc_mps;
    vel.valid = f.velocity_valid;
    vel.counter = status.counter;
    protocol::GnssDop dop{f.hdop, f.pdop, status.counter};
    protocol::GnssTime td = gps_time(unix_t);
    td.counter = status.counter;
    if (f.valid) {
      const protocol::GnssPosition lat{protocol::GnssPositionHalf::kLatitude, f.lat_deg, next(position_counter)};
      const protocol::GnssPosition lon{protocol::GnssPositionHalf::kLongitude, f.lon_deg, next(position_counter)};
      out.push_back({us, 1, protocol::pack(lat)});
      out.push_back({us, 2, protocol::pack(lon)});
    }
    out.push_back({us, 3, protocol::pack(status)});
    out.push_back({us, 4, protocol::pack(vel)});
    out.push_back({us, 5, protocol::pack(dop)});
    out.push_back({us, 6, protocol::pack(td)});
  }
}

}  // namespace

bool write_gnss_vehicle_can_log(const std::string& path, const std::string& file_name, double time_origin_unix_s,
                                std::span<const VehicleSignals> vehicle, std::span<const GnssFix> fixes,
                                Json& can_json, std::string& error) {
  std::vector<TimedCanFrame> out;
  append_vehicle_frames(time_origin_unix_s, vehicle, out);
  append_gnss_frames(time_origin_unix_s, fixes, out);
  std::stable_sort(out.begin(), out.end(), [](const TimedCanFrame& a, const TimedCanFrame& b) {
    return a.us < b.us || (a.us == b.us && a.order < b.order);
  });
  std::ofstream log(path, std::ios::binary);
  CandumpWriter writer(log, "can0");
  for (const auto& e : out) writer.write(e.us, e.frame);
  if (!log) {
    error = "cannot write " + path;
    return false;
  }
  can_json = Json::object();
  can_json["file"] = file_name;
  can_json["format"] = "candump -L: (unix_seconds.microseconds) can0 ID#HEXDATA";
  can_json["frames"] = writer.frames_written();
  can_json["vehicle_motion"] = "0x120 at 100 Hz (wheel speed, yaw rate)";
  can_json["gnss"] = kGnssFrameOrder;
  can_json["layout_version"] = protocol::kCanLayoutVersion;
  can_json["codec"] = "firmware/protocol/can_messages.hpp";
  return true;
}

}  // namespace v2xloc::sim
