// The firmware loop in-process over real loopback sockets with the emulated CAN backend, the
// SimClock driven by sim-time frames and the localizer main() links: after start-up, poll_once()
// performs no heap allocation (global operator new counted), and every frame publishes a pose.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "firmware/app/alloc_counter.hpp"
#include "firmware/app/emulated_wiring.hpp"
#include "firmware/app/firmware_app.hpp"
#include "firmware/app/configure_localizer.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "scripted_io.hpp"
#include "share_signing.hpp"
#include "hal/emulated/emulated_can_bus.hpp"
#include "hal/linux/udp_link.hpp"

namespace v2xloc::firmware {
namespace {

using test::kEpoch;
Localizer g_localizer;
InputDecoder g_decoder(kEpoch);

std::vector<std::vector<std::uint8_t>> cloud_datagrams(protocol::CloudMessageType type, std::uint32_t sender,
                                                       std::uint32_t seq, std::int64_t t_ns, double x_offset) {
  // A box-like room around the sensor, ~3000 points (enough for every stage to run).
  std::vector<float> xyz;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 50; ++j) {
      const double az = 2.0 * 3.14159265358979 * i / 60.0;
      const double el = -0.4 + 0.5 * j / 50.0;
      const double r = 8.0 + 2.0 * std::cos(3.0 * az);
      xyz.push_back(static_cast<float>(r * std::cos(el) * std::cos(az) - x_offset));
      xyz.push_back(static_cast<float>(r * std::cos(el) * std::sin(az)));
      xyz.push_back(static_cast<float>(1.9 + r * std::sin(el)));
    }
  }
  return test::wire_cloud(type, sender, seq, t_ns, xyz);
}

TEST(FirmwareAppLoop, NoHeapAllocationAfterStartUpAndOnePosePerFrame) {
  hal::SimClock clock(0, kEpoch);
  hal::UdpLink fw_can, fw_cloud, fw_ego, tx_can, tx_cloud, tx_ego;
  hal::UdpOptions o;
  o.receive_buffer_bytes = 1 << 21;
  ASSERT_EQ(fw_can.open(o), hal::Status::kOk) << fw_can.last_error();
  ASSERT_EQ(fw_cloud.open(o), hal::Status::kOk) << fw_cloud.last_error();
  ASSERT_EQ(fw_ego.open(o), hal::Status::kOk) << fw_ego.last_error();
  hal::UdpOptions t = o;
  t.has_peer = true;
  t.peer = fw_can.local_endpoint();
  ASSERT_EQ(tx_can.open(t), hal::Status::kOk);
  t.peer = fw_cloud.local_endpoint();
  ASSERT_EQ(tx_cloud.open(t), hal::Status::kOk);
  t.peer = fw_ego.local_endpoint();
  ASSERT_EQ(tx_ego.open(t), hal::Status::kOk);
  ASSERT_EQ(fw_can.set_peer(tx_can.local_endpoint()), hal::Status::kOk);

  hal::EmulatedCanBus fw_bus(fw_can, clock);
  SimTimeCanBus fw_sim_bus(fw_bus, clock);
  hal::SimClock tx_clock;
  hal::EmulatedCanBus tx_bus(tx_can, tx_clock);
  tx_bus.accept_all();
  hal::ScriptedGpioLine pps(clock);
  ASSERT_EQ(script_pps_edges(pps, kEpoch, 10'000'000'000), hal::Status::kOk);
  CountingLedLine led;

  configure_localizer(g_localizer, make_geodetic_origin(48.1374, 11.5755, 520.0));
  static LocalizerAdapter<Localizer> port(g_localizer);
  FirmwareApp app(FirmwareHal{fw_sim_bus, fw_cloud, fw_ego, clock, &pps, &led}, g_decoder, port);
  ASSERT_EQ(app.start(), hal::Status::kOk);

  // Everything the test sends is prepared before the counted loop.
  constexpr int kFrames = 6;
  const auto map = cloud_datagrams(protocol::CloudMessageType::kMapShare, kInfraSenderBase, 0, 0, 0.0);
  std::vector<std::vector<std::vector<std::uint8_t>>> scans;
  for (int i = 0; i < kFrames; ++i) {
    scans.push_back(cloud_datagrams(protocol::CloudMessageType::kEgoScan, kEgoSenderId, static_cast<std::uint32_t>(i),
                                    i * 100'000'000LL, 0.5 * i));
  }
  protocol::VehicleMotion vm;
  vm.wheel_speed_mps = 5.0;
  vm.speed_valid = vm.yaw_rate_valid = true;
  std::vector<hal::CanFrame> vehicle;
  for (int i = 0; i < kFrames; ++i) {
    vm.counter = static_cast<std::uint8_t>(i % protocol::kCounterModulo);
    vehicle.push_back(protocol::pack(vm));
  }
  // The share is signed by a provisioned infrastructure unit: verification (SHA-256 over the
  // cloud, ECDSA P-256) runs inside poll_once(), so the zero-allocation check covers it.
  trust::TrustList list;
  test::add_signer(list, kInfraSenderBase, trust::SignerRole::kInfrastructure);
  g_decoder.provision_trust(list);
  const std::vector<std::uint8_t> signature = test::sign_share(map, kInfraSenderBase, static_cast<std::uint64_t>(kEpoch));

  std::uint64_t allocations = 0;
  auto poll_until = [&](std::uint64_t frames) {
    for (int k = 0; k < 2000 && app.counters().frames_published < frames; ++k) {
      alloc_counter::arm(true);
      app.poll_once();
      alloc_counter::arm(false);
    }
    allocations = alloc_counter::allocations();
  };

  ASSERT_EQ(tx_cloud.send(signature), hal::Status::kOk);
  for (const auto& d : map) ASSERT_EQ(tx_cloud.send(d), hal::Status::kOk);
  for (int i = 0; i < kFrames; ++i) {
    const std::int64_t t_ns = i * 100'000'000LL;
    ASSERT_EQ(tx_bus.send(make_sim_time_frame(t_ns + 1)), hal::Status::kOk);
    ASSERT_EQ(tx_bus.send(vehicle[static_cast<std::size_t>(i)]), hal::Status::kOk);
    for (const auto& d : scans[static_cast<std::size_t>(i)]) ASSERT_EQ(tx_ego.send(d), hal::Status::kOk);
    poll_until(static_cast<std::uint64_t>(i + 1));
    ASSERT_EQ(app.counters().frames_published, static_cast<std::uint64_t>(i + 1));
  }
  EXPECT_EQ(allocations, 0u) << alloc_counter::bytes() << " bytes allocated inside poll_once()";
  EXPECT_EQ(app.decoder().shares().counters().map_clouds, 1u);
  EXPECT_EQ(app.decoder().shares().verifier().counters().accepted, 1u);
  EXPECT_EQ(app.decoder().clouds().counters().ego_scans, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(app.decoder().can().counters().vehicle_inputs, static_cast<std::uint64_t>(kFrames));
  EXPECT_GE(fw_sim_bus.time_frames(), static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(clock.monotonic_ns(), (kFrames - 1) * 100'000'000LL + 1);

  // The pose frames arrive on the test's side of the emulated bus, frame counters 0..kFrames-1,
  // each followed by its diagnostic frames (odometry attitude last, same frame counter).
  int poses = 0, diagnostics = 0;
  hal::CanRxFrame rx;
  while (tx_bus.receive(rx) == hal::Status::kOk) {
    if (rx.frame.id == protocol::kOdometryAttitudeId) {
      protocol::OdometryAttitude odo;
      ASSERT_EQ(protocol::unpack(rx.frame, odo), protocol::DecodeStatus::kOk);
      EXPECT_EQ(odo.frame_counter, diagnostics);
      EXPECT_EQ(poses, diagnostics + 1);  // after this frame's pose
      ++diagnostics;
    }
    if (rx.frame.id != protocol::kPoseAttitudeId) continue;
    protocol::PoseAttitude a;
    ASSERT_EQ(protocol::unpack(rx.frame, a), protocol::DecodeStatus::kOk);
    EXPECT_EQ(a.frame_counter, poses);
    ++poses;
  }
  EXPECT_EQ(poses, kFrames);
  EXPECT_EQ(diagnostics, kFrames);
}

}  // namespace
}  // namespace v2xloc::firmware

namespace v2xloc::firmware {
namespace {

// The counter the loop test relies on does see allocations (no vacuous zero).
TEST(AllocCounter, CountsAllocationsOnlyWhileArmed) {
  const std::uint64_t before = alloc_counter::allocations();
  auto unarmed = std::make_unique<int>(1);
  EXPECT_EQ(alloc_counter::allocations(), before);
  alloc_counter::arm(true);
  auto armed = std::make_unique<std::vector<int>>(100, 7);
  alloc_counter::arm(false);
  EXPECT_EQ(alloc_counter::allocations(), before + 2);  // the vector object + its buffer
  EXPECT_GE(alloc_counter::bytes(), 400u);
}

}  // namespace
}  // namespace v2xloc::firmware
