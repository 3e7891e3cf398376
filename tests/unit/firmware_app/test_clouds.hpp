// Test support for the wire decoder tests: clouds fragmented as a sender puts them on the wire.
#pragma once

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/wire/wire_conventions.hpp"

namespace v2xloc::firmware::test {

// Disciplined time of localizer time 0 in the decoder tests.
inline constexpr std::int64_t kEpoch = 1'700'000'000'000'000'000;

// The header of a cloud stamped kEpoch + stamp_ns, sensor at (9.5, 0, 5) m, 4 mm quantization.
inline protocol::CloudFrameInfo cloud_info(protocol::CloudMessageType type, std::uint32_t sender, std::uint32_t seq,
                                           std::int64_t stamp_ns) {
  protocol::CloudFrameInfo info;
  info.type = type;
  info.sender_id = sender;
  info.frame_seq = seq;
  info.timestamp_ns = static_cast<std::uint64_t>(kEpoch + stamp_ns);
  info.pose.position_m[0] = 9.5;
  info.pose.position_m[2] = 5.0;
  info.scale_m = kCloudScaleM;
  return info;
}

// The datagrams of the cloud `info` (fragments of at most 1400 bytes, in send order).
inline std::vector<std::vector<std::uint8_t>> fragment_frame(const protocol::CloudFrameInfo& info,
                                                             const std::vector<float>& xyz,
                                                             const std::vector<std::uint16_t>& times = {}) {
  protocol::PointCloudFragmenter f;
  EXPECT_EQ(f.begin(info, protocol::CloudPointsView{xyz, {}, times}), protocol::CloudStatus::kOk);
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> buf(1400);
  std::size_t n = 0;
  while (f.next(buf, n) == protocol::CloudStatus::kOk) out.emplace_back(buf.begin(), buf.begin() + static_cast<long>(n));
  return out;
}

inline std::vector<std::vector<std::uint8_t>> fragment_cloud(protocol::CloudMessageType type, std::uint32_t sender,
                                                             std::uint32_t seq, std::int64_t stamp_ns,
                                                             const std::vector<float>& xyz,
                                                             const std::vector<std::uint16_t>& times = {}) {
  return fragment_frame(cloud_info(type, sender, seq, stamp_ns), xyz, times);
}

// n points on a ramp (x y z floats).
inline std::vector<float> ramp_points(std::size_t n) {
  std::vector<float> xyz;
  for (std::size_t i = 0; i < n; ++i) {
    xyz.push_back(0.01f * static_cast<float>(i));
    xyz.push_back(-0.02f * static_cast<float>(i % 100));
    xyz.push_back(1.5f);
  }
  return xyz;
}

}  // namespace v2xloc::firmware::test
