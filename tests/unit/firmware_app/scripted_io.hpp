// The firmware application's scripted I/O for tests: datagram links and a CAN bus fed from
// queues (with an optional gate: readable only once another link was read), a localizer port that
// records its calls, and a small cloud fragmented as the wire carries it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/wire/localizer_port.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "hal/can_bus.hpp"
#include "hal/clock.hpp"
#include "hal/datagram_link.hpp"

namespace v2xloc::firmware::test {

inline constexpr std::int64_t kEpoch = 1'700'000'000'000'000'000;

using Datagram = std::vector<std::uint8_t>;

// A datagram endpoint fed by the test. `gate` (optional) holds this link's datagrams back until
// another link has been read `after_reads` times: the V2X share that "arrives" while the firmware
// is busy reading the ego socket.
class ScriptedLink final : public hal::DatagramLink {
 public:
  hal::Status send(std::span<const std::uint8_t>) override { return hal::Status::kOk; }
  hal::Status send_to(const hal::Ipv4Endpoint&, std::span<const std::uint8_t>) override { return hal::Status::kOk; }
  hal::Status receive(std::span<std::uint8_t> buffer, hal::DatagramInfo& info) override {
    ++reads;
    if (gate != nullptr && gate->reads < after_reads) return hal::Status::kWouldBlock;
    if (queue.empty()) return hal::Status::kWouldBlock;
    const Datagram d = queue.front();
    queue.pop_front();
    if (d.size() > buffer.size()) return hal::Status::kBufferTooSmall;
    std::copy(d.begin(), d.end(), buffer.begin());
    info.size = d.size();
    return hal::Status::kOk;
  }
  std::deque<Datagram> queue;
  const ScriptedLink* gate = nullptr;
  int after_reads = 0;
  int reads = 0;
};

// A CAN bus fed by the test (the SimTimeCanBus on top turns sim-time frames into clock steps).
class ScriptedCan final : public hal::CanBus {
 public:
  hal::Status send(const hal::CanFrame& f) override {
    sent.push_back(f);
    return hal::Status::kOk;
  }
  std::vector<hal::CanFrame> sent;
  hal::Status receive(hal::CanRxFrame& out) override {
    if (gate != nullptr && gate->reads < after_reads) return hal::Status::kWouldBlock;
    if (queue.empty()) return hal::Status::kWouldBlock;
    out = hal::CanRxFrame{};
    if (clock != nullptr) out.timestamp_ns = clock->monotonic_ns();
    out.frame = queue.front();
    queue.pop_front();
    return hal::Status::kOk;
  }
  hal::Status set_filters(std::span<const hal::CanFilter>) override { return hal::Status::kOk; }
  hal::Status accept_all() override { return hal::Status::kOk; }
  hal::Status set_error_mask(std::uint32_t) override { return hal::Status::kOk; }
  hal::CanCounters counters() const override { return {}; }
  std::deque<hal::CanFrame> queue;
  const hal::Clock* clock = nullptr;  // stamps received frames (else 0), as the emulated bus does
  const ScriptedLink* gate = nullptr;
  int after_reads = 0;
};

// Records the order of the localizer calls and the ego scans it was given.
class RecordingPort final : public LocalizerPort {
 public:
  void on_vehicle(const VehicleInput&) override { calls += "v"; }
  void on_gnss(const GnssInput&) override { calls += "g"; }
  void on_imu(const ImuInput&) override { calls += "i"; }
  MapInsertResult on_map_cloud(const MapCloudInput&) override {
    calls += "m";
    MapInsertResult r;
    r.status = insert_status;
    return r;
  }
  MapInsertStatus insert_status = MapInsertStatus::kInvalidInput;  // what map fusion answers
  const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& scan) override {
    calls += "e";
    scan_t.push_back(scan.t);
    scan_points.push_back(scan.points.size());
    return output_;
  }
  std::string calls;
  std::vector<double> scan_t;             // each ego scan's stamp [s]
  std::vector<std::size_t> scan_points;   // and its points

 private:
  LocalizerFrameOutput output_{};
};

// `xyz` (sensor frame, metres) stamped kEpoch + t_ns as the wire's datagrams, at most max_bytes each.
// frame_seq: a sender's clouds must differ in it (the reassembler drops a repeated one as stale).
inline std::vector<Datagram> wire_cloud(protocol::CloudMessageType type, std::uint32_t sender, std::uint32_t frame_seq,
                                        std::int64_t t_ns, const std::vector<float>& xyz,
                                        std::size_t max_bytes = protocol::pointcloud_wire::kMaxDatagramBytes) {
  protocol::CloudFrameInfo info;
  info.type = type;
  info.sender_id = sender;
  info.frame_seq = frame_seq;
  info.timestamp_ns = static_cast<std::uint64_t>(kEpoch + t_ns);
  info.scale_m = kCloudScaleM;
  protocol::PointCloudFragmenter f;
  EXPECT_EQ(f.begin(info, protocol::CloudPointsView{xyz, {}, {}}, max_bytes), protocol::CloudStatus::kOk);
  std::vector<Datagram> out;
  Datagram buf(max_bytes);
  std::size_t n = 0;
  while (f.next(buf, n) == protocol::CloudStatus::kOk) out.emplace_back(buf.begin(), buf.begin() + static_cast<long>(n));
  return out;
}

// A small 600-point cloud in 600-byte datagrams.
inline std::vector<Datagram> cloud(protocol::CloudMessageType type, std::uint32_t sender, std::int64_t t_ns,
                                   std::uint32_t frame_seq = 0) {
  std::vector<float> xyz;
  for (int i = 0; i < 600; ++i) xyz.insert(xyz.end(), {0.01f * i, 5.0f - 0.01f * i, 1.0f});
  return wire_cloud(type, sender, frame_seq, t_ns, xyz, 600);
}

}  // namespace v2xloc::firmware::test
