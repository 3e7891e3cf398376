// The firmware's input order does not depend on socket read timing: a map share received on the
// V2X endpoint before an ego scan reaches map fusion before that scan even when the ego endpoint
// happened to be read first, and its freshness is judged by the clock of the period boundary, not
// by how far the emulated clock had moved when its datagrams were read. Also the schedule of the
// decoder's share verification queue.
#include <gtest/gtest.h>

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "firmware/app/emulated_wiring.hpp"
#include "firmware/app/firmware_app.hpp"
#include "firmware/wire/share_schedule.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "scripted_io.hpp"
#include "share_signing.hpp"

namespace v2xloc::firmware {
namespace {

using test::cloud;
using test::kEpoch;
using test::RecordingPort;
using test::ScriptedCan;
using test::ScriptedLink;


// One period at kT: a signed share and an ego scan, both stamped kT, and the sim-time frame that
// moves the emulated clock to kT. The CAN frame becomes readable once the ego endpoint was read
// (the replayer sends it just before the scan); the share's datagrams once the ego endpoint was
// read `share_after_ego_reads` times. Returns the localizer calls ("m" map, "e" ego scan).
struct PeriodOutcome {
  std::string calls;
  std::uint64_t accepted = 0, future = 0, published = 0;
  std::int64_t clock_ns = 0;
};

// A signed infrastructure share and an ego scan, both stamped t, and the sim-time frame that
// moves the emulated clock to t.
void queue_signed_period(ScriptedLink& v2x, ScriptedLink& ego, ScriptedCan& can, std::int64_t t) {
  const auto share = cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, t);
  v2x.queue.push_back(test::sign_share(share, kInfraSenderBase, static_cast<std::uint64_t>(kEpoch + t)));
  for (const auto& d : share) v2x.queue.push_back(d);
  for (const auto& d : cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, t)) ego.queue.push_back(d);
  can.queue.push_back(make_sim_time_frame(t));
}

// A decoder whose trust list names the infrastructure signer of queue_signed_period.
std::unique_ptr<InputDecoder> decoder_trusting_infra() {
  auto decoder = std::make_unique<InputDecoder>(kEpoch);
  trust::TrustList list;
  test::add_signer(list, kInfraSenderBase, trust::SignerRole::kInfrastructure);
  decoder->provision_trust(list);
  return decoder;
}

// The firmware over one signed period (queue_signed_period at kT) on scripted links, its decoder
// trusting the infrastructure signer, its localizer a recording port.
struct SignedPeriodBench {
  static constexpr std::int64_t kT = 100'000'000;
  hal::SimClock clock{0, kEpoch};
  ScriptedCan can;
  SimTimeCanBus sim_can{can, clock};
  ScriptedLink v2x, ego;
  std::unique_ptr<InputDecoder> decoder = decoder_trusting_infra();
  RecordingPort port;
  FirmwareApp app{FirmwareHal{sim_can, v2x, ego, clock, nullptr, nullptr}, *decoder, port};

  SignedPeriodBench() { queue_signed_period(v2x, ego, can, kT); }
  // Starts the firmware and polls until it publishes the period's frame (at most 10 polls).
  hal::Status start_and_run_period() {
    const hal::Status started = app.start();
    for (int k = 0; k < 10 && app.counters().frames_published == 0; ++k) app.poll_once();
    return started;
  }
};

PeriodOutcome run_one_period(int share_after_ego_reads) {
  SignedPeriodBench b;
  b.v2x.gate = &b.ego;
  b.v2x.after_reads = share_after_ego_reads;
  b.can.gate = &b.ego;
  b.can.after_reads = 1;
  EXPECT_EQ(b.start_and_run_period(), hal::Status::kOk);
  PeriodOutcome out;
  out.calls = b.port.calls;
  out.accepted = b.app.decoder().shares().verifier().counters().accepted;
  out.future = b.app.decoder().shares().verifier().counters().future;
  out.published = b.app.counters().frames_published;
  out.clock_ns = b.clock.monotonic_ns();
  return out;
}

// The share becomes readable only while the firmware reads the scan (it looked at the V2X socket
// too early): it still reaches map fusion before the scan of its period.
TEST(FirmwarePeriodOrder, ShareReadAfterTheScanStartedIsFusedBeforeTheScan) {
  const PeriodOutcome o = run_one_period(2);
  EXPECT_EQ(o.published, 1u);
  EXPECT_EQ(o.calls, "me");
  EXPECT_EQ(o.accepted, 1u);
  EXPECT_EQ(o.clock_ns, 100'000'000);
}

// The share completes while the emulated clock still reads 0 (its sim-time frame not read yet),
// 100 ms before its generation time: judged by the boundary's clock, it is fresh, as offline.
TEST(FirmwarePeriodOrder, ShareFreshnessIsJudgedByThePeriodBoundaryClock) {
  const PeriodOutcome o = run_one_period(0);
  EXPECT_EQ(o.published, 1u);
  EXPECT_EQ(o.calls, "me");
  EXPECT_EQ(o.accepted, 1u);
  EXPECT_EQ(o.future, 0u);
}

// What was refused reaches the vehicle bus: with the heartbeat, 0x301 (trust layer, per reason)
// and 0x302 (input guards) carry the counts.
TEST(FirmwareSecurityDiagnostics, HeartbeatIsFollowedByTheRefusalCounts) {
  hal::SimClock clock(0, kEpoch);
  ScriptedCan can;
  SimTimeCanBus sim_can(can, clock);
  ScriptedLink v2x, ego;
  // An unsigned share, a vehicle frame with a broken CRC, the same vehicle frame twice (its
  // rolling counter does not advance), the same for the GNSS latitude and time frames (layout 2
  // gave them a counter and a CRC), an ego scan dated 10 s ahead, then 1.1 s of time.
  for (const auto& d : cloud(protocol::CloudMessageType::kMapShare, kInfraSenderBase, 0)) v2x.queue.push_back(d);
  protocol::VehicleMotion vm;
  vm.speed_valid = vm.yaw_rate_valid = true;
  hal::CanFrame good = protocol::pack(vm), bad = good;
  bad.data[0] ^= 0x01;
  const hal::CanFrame time = protocol::pack(protocol::GnssTime{100.0, 2300, 3});
  hal::CanFrame bad_lat = protocol::pack(protocol::GnssPosition{protocol::GnssPositionHalf::kLatitude, 48.0, 0});
  bad_lat.data[3] ^= 0x40;
  can.queue = {make_sim_time_frame(50'000'000), bad, good, good, bad_lat, time, time};
  for (const auto& d : cloud(protocol::CloudMessageType::kEgoScan, kEgoSenderId, 10'000'000'000)) ego.queue.push_back(d);

  auto decoder = std::make_unique<InputDecoder>(kEpoch);
  RecordingPort port;
  FirmwareApp app(FirmwareHal{sim_can, v2x, ego, clock, nullptr, nullptr}, *decoder, port);
  ASSERT_EQ(app.start(), hal::Status::kOk);
  for (int k = 0; k < 10 && app.counters().frames_published == 0; ++k) app.poll_once();
  ASSERT_EQ(app.counters().frames_published, 1u);
  can.queue.push_back(make_sim_time_frame(1'100'000'000));
  app.poll_once();
  ASSERT_EQ(app.counters().heartbeats, 1u);

  int found = 0;
  for (std::size_t i = 0; i < can.sent.size(); ++i) {
    if (can.sent[i].id == protocol::kTrustRejectionsId) {
      ASSERT_GT(i, 0u);
      EXPECT_EQ(can.sent[i - 1].id, protocol::kHeartbeatId) << "sent right after the heartbeat";
      protocol::TrustRejections t;
      ASSERT_EQ(protocol::unpack(can.sent[i], t), protocol::DecodeStatus::kOk);
      EXPECT_EQ(t.unknown_signer + t.bad_signature + t.too_old + t.future + t.replay + t.queue_overflow + t.pose_mismatch, 0);
      ++found;
    }
    if (can.sent[i].id == protocol::kInputGuardsId) {
      protocol::InputGuards g;
      ASSERT_EQ(protocol::unpack(can.sent[i], g), protocol::DecodeStatus::kOk);
      EXPECT_EQ(g.can_crc_rejected, 2u);
      EXPECT_EQ(g.can_counter_rejected, 2u);
      EXPECT_EQ(g.ego_time_rejected, 1u);
      EXPECT_EQ(g.missing_signature, 1u);
      ++found;
    }
  }
  EXPECT_EQ(found, 2);
}

// A signed share that map fusion refuses as off its unit's surveyed background is counted and
// reaches the vehicle bus in 0x302 with the next heartbeat.
TEST(FirmwareSecurityDiagnostics, SurveyedBackgroundRefusalIsReportedOn0x302) {
  SignedPeriodBench b;
  b.port.insert_status = MapInsertStatus::kBackgroundMismatch;
  FirmwareApp& app = b.app;
  ASSERT_EQ(b.start_and_run_period(), hal::Status::kOk);
  ASSERT_EQ(app.counters().frames_published, 1u);
  ASSERT_EQ(b.port.calls, "me");
  EXPECT_EQ(app.period_counters().map_background_mismatch, 1u);
  b.can.queue.push_back(make_sim_time_frame(1'100'000'000));
  app.poll_once();
  ASSERT_EQ(app.counters().heartbeats, 1u);
  int found = 0;
  for (const hal::CanFrame& f : b.can.sent) {
    if (f.id != protocol::kInputGuardsId) continue;
    protocol::InputGuards g;
    ASSERT_EQ(protocol::unpack(f, g), protocol::DecodeStatus::kOk);
    EXPECT_EQ(g.background_mismatch, 1u);
    EXPECT_EQ(g.missing_signature, 0u);
    ++found;
  }
  EXPECT_EQ(found, 1);
}

TEST(SharePeriodSchedule, KeepsTheNewestCapacityAndReleasesAtMostPerPeriodOldestFirst) {
  SharePeriodSchedule<4, 2> s;
  std::vector<std::size_t> slot_of(6);
  int dropped = 0;
  for (int k = 0; k < 6; ++k) {
    const auto a = s.admit();
    slot_of[static_cast<std::size_t>(k)] = a.slot;
    dropped += a.dropped_oldest ? 1 : 0;
  }
  EXPECT_EQ(dropped, 2);
  EXPECT_EQ(s.waiting(), 4u);
  std::size_t slot = 99;
  s.begin_period();
  ASSERT_TRUE(s.release(slot));
  EXPECT_EQ(slot, slot_of[2]);  // shares 0 and 1 gave way
  ASSERT_TRUE(s.release(slot));
  EXPECT_EQ(slot, slot_of[3]);
  EXPECT_FALSE(s.release(slot)) << "budget of the period spent";
  s.refund();  // the last one needed no verification after all
  ASSERT_TRUE(s.release(slot));
  EXPECT_EQ(slot, slot_of[4]);
  EXPECT_FALSE(s.release(slot));
  s.begin_period();
  ASSERT_TRUE(s.release(slot));
  EXPECT_EQ(slot, slot_of[5]);
  EXPECT_FALSE(s.release(slot)) << "empty";
  EXPECT_EQ(s.waiting(), 0u);
  // The constants the firmware and the evaluator share.
  static_assert(ShareSchedule::kCapacity == kShareVerifyQueueCapacity);
  static_assert(ShareSchedule::kPerPeriod == kMaxSignatureVerificationsPerPeriod);
}

}  // namespace
}  // namespace v2xloc::firmware
