// Helpers shared by the UDP point-cloud tests: synthetic clouds, fragmenting into datagrams,
// re-sealing a tampered datagram with a valid CRC (to test the checks behind the CRC).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "firmware/protocol/crc32.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"

namespace v2xloc::protocol::test {

struct SyntheticCloud {
  std::vector<float> xyz;
  std::vector<std::uint8_t> intensity;
  std::vector<std::uint16_t> time_ticks;
  CloudPointsView view(bool with_intensity = true, bool with_time = true) const {
    return CloudPointsView{xyz, with_intensity ? std::span<const std::uint8_t>(intensity) : std::span<const std::uint8_t>{},
                           with_time ? std::span<const std::uint16_t>(time_ticks) : std::span<const std::uint16_t>{}};
  }
};

inline SyntheticCloud make_cloud(std::size_t n, float range_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coord(-range_m, range_m);
  SyntheticCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.xyz.push_back(coord(rng));
    c.xyz.push_back(coord(rng));
    c.xyz.push_back(coord(rng));
    c.intensity.push_back(static_cast<std::uint8_t>(rng()));
    c.time_ticks.push_back(static_cast<std::uint16_t>(rng()));
  }
  return c;
}

inline CloudFrameInfo make_info(std::uint32_t seq, CoordWidth width = CoordWidth::kInt16, float scale = 0.002f) {
  CloudFrameInfo info;
  info.type = CloudMessageType::kMapShare;
  info.sender_id = 0xA1B2C3D4u;
  info.sensor_id = 7;
  info.frame_seq = seq;
  info.timestamp_ns = 1'700'000'000'123'456'789ull;
  info.pose.position_m[0] = 691234.125;
  info.pose.position_m[1] = 5334567.5;
  info.pose.position_m[2] = 512.25;
  info.pose.quaternion_xyzw[0] = 0.0;
  info.pose.quaternion_xyzw[1] = 0.0;
  info.pose.quaternion_xyzw[2] = 0.38268343236508978;
  info.pose.quaternion_xyzw[3] = 0.92387953251128674;
  info.scale_m = scale;
  info.width = width;
  return info;
}

using Datagrams = std::vector<std::vector<std::uint8_t>>;

inline CloudStatus fragment_all(const CloudFrameInfo& info, const CloudPointsView& points, Datagrams& out,
                                PointCloudFragmenter* used = nullptr,
                                std::size_t max_bytes = pointcloud_wire::kMaxDatagramBytes) {
  PointCloudFragmenter f;
  CloudStatus s = f.begin(info, points, max_bytes);
  if (s != CloudStatus::kOk) return s;
  std::vector<std::uint8_t> buf(pointcloud_wire::kMaxDatagramBytes);
  for (;;) {
    std::size_t written = 0;
    s = f.next(buf, written);
    if (s == CloudStatus::kDone) break;
    if (s != CloudStatus::kOk) return s;
    out.emplace_back(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(written));
  }
  if (used != nullptr) *used = f;
  return CloudStatus::kOk;
}

inline void put_le(std::vector<std::uint8_t>& d, std::size_t offset, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) d[offset + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(value >> (8 * i));
}

inline std::uint64_t get_le(const std::vector<std::uint8_t>& d, std::size_t offset, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | d[offset + static_cast<std::size_t>(i)];
  return v;
}

// Recompute the CRC trailer after tampering with the header, so deeper checks are reached.
inline void reseal(std::vector<std::uint8_t>& d) {
  const std::size_t body = d.size() - pointcloud_wire::kTrailerBytes;
  put_le(d, body, crc32(std::span<const std::uint8_t>(d.data(), body)), 4);
}

}  // namespace v2xloc::protocol::test
