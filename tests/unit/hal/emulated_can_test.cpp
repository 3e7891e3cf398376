// CAN over UDP between two endpoints on 127.0.0.1: bit-exact round trips, order, filters, error
// frames, malformed datagrams, time stamps from the simulated clock.
#include "hal/emulated/emulated_can_bus.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include <array>
#include <cstring>
#include <ctime>
#include <random>
#include <vector>

#include "hal/emulated/sim_clock.hpp"
#include "hal/linux/udp_link.hpp"
#include "hal/socketcan_frame.hpp"

namespace v2xloc::hal {
namespace {

std::int64_t mono_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// Two UDP endpoints connected to each other, each carrying one side of the emulated bus.
struct Pair {
  UdpLink link_a, link_b;
  SimClock clock{5'000};
  Pair() {
    EXPECT_EQ(link_a.open(UdpOptions{}), Status::kOk) << link_a.last_error();
    EXPECT_EQ(link_b.open(UdpOptions{}), Status::kOk) << link_b.last_error();
    link_a.set_peer(link_b.local_endpoint());
    link_b.set_peer(link_a.local_endpoint());
  }
};

Status receive_wait(CanBus& bus, CanRxFrame& rx) {
  const std::int64_t give_up = mono_now() + 2'000'000'000;
  Status s;
  while ((s = bus.receive(rx)) == Status::kWouldBlock && mono_now() < give_up) {
  }
  return s;
}

TEST(EmulatedCan, RandomFramesRoundTripBitExactAndInOrder) {
  Pair p;
  EmulatedCanBus a(p.link_a, p.clock), b(p.link_b, p.clock);
  std::mt19937 rng(7);
  std::vector<hal::CanFrame> sent;
  for (int i = 0; i < 500; ++i) {
    hal::CanFrame f;
    const bool extended = (rng() & 3) == 0;
    f.id = extended ? ((rng() & 0x1FFFFFFFu) | hal::CanFrame::kExtendedFlag) : (rng() & 0x7FFu);
    f.dlc = static_cast<std::uint8_t>(rng() % 9);
    for (int k = 0; k < f.dlc; ++k) f.data[k] = static_cast<std::uint8_t>(rng());
    ASSERT_EQ(a.send(f), Status::kOk);
    sent.push_back(f);
    if (i % 50 == 49) {  // drain as we go so the socket buffer never overflows
      for (int k = 0; k < 50; ++k) {
        CanRxFrame rx;
        ASSERT_EQ(receive_wait(b, rx), Status::kOk);
        const auto& want = sent[sent.size() - 50 + static_cast<std::size_t>(k)];
        ASSERT_EQ(rx.frame.id, want.id);
        ASSERT_EQ(rx.frame.dlc, want.dlc);
        ASSERT_EQ(std::memcmp(rx.frame.data, want.data, 8), 0);
        ASSERT_FALSE(rx.error);
        ASSERT_EQ(rx.timestamp_ns, p.clock.monotonic_ns());
      }
      p.clock.advance_by(1'000'000);
    }
  }
  EXPECT_EQ(a.counters().tx_frames, 500u);
  EXPECT_EQ(b.counters().rx_frames, 500u);
}

TEST(EmulatedCan, DatagramBytesAreExactlyStructCanFrame) {
  Pair p;
  EmulatedCanBus a(p.link_a, p.clock);
  hal::CanFrame f;
  f.id = 0x18FEF100u | hal::CanFrame::kExtendedFlag;
  f.dlc = 2;
  f.data[0] = 0x11;
  f.data[1] = 0x22;
  ASSERT_EQ(a.send(f), Status::kOk);
  std::array<std::uint8_t, 64> raw{};
  DatagramInfo info;
  const std::int64_t give_up = mono_now() + 2'000'000'000;
  Status s;
  while ((s = p.link_b.receive(raw, info)) == Status::kWouldBlock && mono_now() < give_up) {
  }
  ASSERT_EQ(s, Status::kOk);
  ASSERT_EQ(info.size, sizeof(struct can_frame));
  struct can_frame cf;
  std::memcpy(&cf, raw.data(), sizeof cf);
  EXPECT_EQ(cf.can_id, 0x18FEF100u | CAN_EFF_FLAG);
  EXPECT_EQ(cf.len, 2);
  EXPECT_EQ(cf.data[1], 0x22);
}

TEST(EmulatedCan, FiltersAndErrorMaskFollowCanRaw) {
  Pair p;
  EmulatedCanBus a(p.link_a, p.clock), b(p.link_b, p.clock);
  const CanFilter filters[] = {{0x100, CanFilter::kStandardMask},
                               {0x200 | hal::CanFrame::kExtendedFlag, 0x700 | hal::CanFrame::kExtendedFlag}};
  ASSERT_EQ(b.set_filters(filters), Status::kOk);
  const std::uint32_t ids[] = {0x100, 0x101, 0x200, 0x200 | hal::CanFrame::kExtendedFlag,
                               0x2AB | hal::CanFrame::kExtendedFlag, 0x300 | hal::CanFrame::kExtendedFlag};
  for (const std::uint32_t id : ids) {
    hal::CanFrame f;
    f.id = id;
    f.dlc = 1;
    ASSERT_EQ(a.send(f), Status::kOk);
  }
  // An error frame: not delivered with the default (empty) error mask, delivered once enabled.
  struct can_frame err;
  std::memset(&err, 0, sizeof err);
  err.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  err.len = CAN_ERR_DLC;
  std::array<std::uint8_t, 16> err_bytes{};
  std::memcpy(err_bytes.data(), &err, sizeof err);
  ASSERT_EQ(a.send_raw(err_bytes), Status::kOk);
  hal::CanFrame sentinel;  // accepted; arriving last, it proves everything before was seen
  sentinel.id = 0x100;
  sentinel.dlc = 1;
  sentinel.data[0] = 0xEE;
  ASSERT_EQ(a.send(sentinel), Status::kOk);
  std::vector<std::uint32_t> got;
  CanRxFrame rx;
  while (got.size() < 4 && receive_wait(b, rx) == Status::kOk) got.push_back(rx.frame.id);
  EXPECT_EQ(rx.frame.data[0], 0xEE);
  EXPECT_EQ(got, (std::vector<std::uint32_t>{0x100, 0x200 | hal::CanFrame::kExtendedFlag,
                                              0x2AB | hal::CanFrame::kExtendedFlag, 0x100}));
  EXPECT_EQ(b.receive(rx), Status::kWouldBlock);
  EXPECT_EQ(b.counters().rx_filtered, 4u);  // 0x101, 0x200 std, 0x300 ext, error frame

  ASSERT_EQ(b.set_error_mask(can_error::kBusOff), Status::kOk);
  ASSERT_EQ(a.send_raw(err_bytes), Status::kOk);
  ASSERT_EQ(receive_wait(b, rx), Status::kOk);
  EXPECT_TRUE(rx.error);
  EXPECT_EQ(rx.error_class, can_error::kBusOff);
  EXPECT_EQ(b.counters().rx_errors, 1u);
}

TEST(EmulatedCan, MalformedDatagramsAreCountedAndSkipped) {
  Pair p;
  EmulatedCanBus b(p.link_b, p.clock);
  const std::array<std::uint8_t, 15> short_frame{};
  std::array<std::uint8_t, 16> bad_len{};
  bad_len[4] = 12;
  std::array<std::uint8_t, 200> huge{};
  ASSERT_EQ(p.link_a.send(short_frame), Status::kOk);
  ASSERT_EQ(p.link_a.send(bad_len), Status::kOk);
  ASSERT_EQ(p.link_a.send(huge), Status::kOk);
  EmulatedCanBus a(p.link_a, p.clock);
  hal::CanFrame good;
  good.id = 0x7FF;
  good.dlc = 0;
  ASSERT_EQ(a.send(good), Status::kOk);
  CanRxFrame rx;
  EXPECT_EQ(receive_wait(b, rx), Status::kMalformed);
  EXPECT_EQ(receive_wait(b, rx), Status::kMalformed);
  EXPECT_EQ(receive_wait(b, rx), Status::kMalformed);
  ASSERT_EQ(receive_wait(b, rx), Status::kOk);
  EXPECT_EQ(rx.frame.id, 0x7FFu);
  EXPECT_EQ(b.counters().rx_malformed, 3u);
}

}  // namespace
}  // namespace v2xloc::hal
