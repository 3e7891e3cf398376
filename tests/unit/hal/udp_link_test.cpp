// POSIX UDP backend on 127.0.0.1, for real.
#include "hal/linux/udp_link.hpp"

#include <gtest/gtest.h>

#include <array>
#include <ctime>
#include <vector>

namespace v2xloc::hal {
namespace {

constexpr std::uint32_t kLoopback = 0x7F000001u;

std::int64_t mono_now() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// Loopback delivery is immediate in practice; poll briefly anyway instead of assuming it.
Status receive_wait(DatagramLink& link, std::span<std::uint8_t> buf, DatagramInfo& info) {
  const std::int64_t give_up = mono_now() + 2'000'000'000;
  Status s;
  while ((s = link.receive(buf, info)) == Status::kWouldBlock && mono_now() < give_up) {
  }
  return s;
}

TEST(UdpLink, RoundTripOnLoopbackWithSourceAndTimestamp) {
  UdpLink a, b;
  ASSERT_EQ(a.open(UdpOptions{}), Status::kOk) << a.last_error();
  ASSERT_EQ(b.open(UdpOptions{}), Status::kOk) << b.last_error();
  ASSERT_NE(a.local_endpoint().port, 0);
  std::array<std::uint8_t, 1400> out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>(i * 7);
  const std::int64_t before = mono_now();
  ASSERT_EQ(a.send_to(b.local_endpoint(), out), Status::kOk) << a.last_error();
  std::array<std::uint8_t, 2048> in{};
  DatagramInfo info;
  ASSERT_EQ(receive_wait(b, in, info), Status::kOk) << b.last_error();
  const std::int64_t after = mono_now();
  ASSERT_EQ(info.size, out.size());
  EXPECT_TRUE(std::equal(out.begin(), out.end(), in.begin()));
  EXPECT_EQ(info.from, a.local_endpoint());
  EXPECT_GE(info.timestamp_ns, before - 1'000'000);
  EXPECT_LE(info.timestamp_ns, after + 1'000'000);
  EXPECT_EQ(b.receive(in, info), Status::kWouldBlock);  // non-blocking when empty
}

TEST(UdpLink, ConnectedPeerPreservesOrder) {
  UdpLink rx;
  ASSERT_EQ(rx.open(UdpOptions{}), Status::kOk);
  UdpOptions o;
  o.has_peer = true;
  o.peer = rx.local_endpoint();
  o.connect_peer = true;
  UdpLink tx;
  ASSERT_EQ(tx.open(o), Status::kOk) << tx.last_error();
  for (std::uint32_t i = 0; i < 200; ++i) {
    const std::array<std::uint8_t, 4> d = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i >> 8), 0, 0};
    ASSERT_EQ(tx.send(d), Status::kOk) << tx.last_error();
  }
  std::array<std::uint8_t, 16> in{};
  for (std::uint32_t i = 0; i < 200; ++i) {
    DatagramInfo info;
    ASSERT_EQ(receive_wait(rx, in, info), Status::kOk);
    ASSERT_EQ(info.size, 4u);
    EXPECT_EQ(in[0] | (in[1] << 8), static_cast<int>(i));
  }
}

TEST(UdpLink, OversizedDatagramIsReportedNotTruncatedSilently) {
  UdpLink a, b;
  ASSERT_EQ(a.open(UdpOptions{}), Status::kOk);
  ASSERT_EQ(b.open(UdpOptions{}), Status::kOk);
  std::vector<std::uint8_t> big(600, 0xAB);
  ASSERT_EQ(a.send_to(b.local_endpoint(), big), Status::kOk);
  ASSERT_EQ(a.send_to(b.local_endpoint(), std::span<const std::uint8_t>(big.data(), 8)), Status::kOk);
  std::array<std::uint8_t, 100> small{};
  DatagramInfo info;
  EXPECT_EQ(receive_wait(b, small, info), Status::kBufferTooSmall);
  EXPECT_EQ(info.size, 0u);
  ASSERT_EQ(receive_wait(b, small, info), Status::kOk);  // the next datagram is intact
  EXPECT_EQ(info.size, 8u);
}

TEST(UdpLink, ErrorsAreStatusesWithReasons) {
  UdpLink a;
  std::array<std::uint8_t, 4> d{};
  EXPECT_EQ(a.send(d), Status::kNotOpen);
  UdpLink first;
  ASSERT_EQ(first.open(UdpOptions{}), Status::kOk);
  UdpOptions clash;
  clash.bind = first.local_endpoint();
  EXPECT_NE(a.open(clash), Status::kOk);
  EXPECT_NE(std::string(a.last_error()).find("bind(udp) failed: Address already in use"), std::string::npos)
      << a.last_error();
  std::uint32_t addr = 0;
  EXPECT_TRUE(parse_ipv4("192.168.1.20", addr));
  EXPECT_EQ(addr, 0xC0A80114u);
  EXPECT_FALSE(parse_ipv4("192.168.1.256", addr));
  EXPECT_FALSE(parse_ipv4("1.2.3", addr));
  EXPECT_FALSE(parse_ipv4("1.2.3.4x", addr));
}

TEST(UdpLink, MulticastOnLoopbackWhenTheKernelAllowsIt) {
  std::uint32_t group = 0;
  ASSERT_TRUE(parse_ipv4("239.255.42.1", group));
  UdpOptions ro;
  ro.bind = Ipv4Endpoint{0, 0};  // INADDR_ANY, ephemeral
  ro.multicast_group = group;
  ro.multicast_interface = kLoopback;
  UdpLink rx;
  if (rx.open(ro) != Status::kOk) GTEST_SKIP() << "multicast join on lo refused: " << rx.last_error();
  UdpOptions to;
  to.multicast_interface = kLoopback;
  UdpLink tx;
  ASSERT_EQ(tx.open(to), Status::kOk);
  std::array<std::uint8_t, 3> d = {1, 2, 3};
  const Status sent = tx.send_to(Ipv4Endpoint{group, rx.local_endpoint().port}, d);
  if (sent != Status::kOk) GTEST_SKIP() << "multicast send refused: " << tx.last_error();
  std::array<std::uint8_t, 16> in{};
  DatagramInfo info;
  const Status got = receive_wait(rx, in, info);
  if (got == Status::kWouldBlock) GTEST_SKIP() << "no multicast route over lo in this network namespace";
  ASSERT_EQ(got, Status::kOk);
  EXPECT_EQ(info.size, 3u);
}

}  // namespace
}  // namespace v2xloc::hal
