// Loss, truncation, corruption, lying headers, timeouts and eviction: statuses and counters.
#include <gtest/gtest.h>

#include <memory>

#include "cloud_test_util.hpp"

namespace v2xloc::protocol {
namespace {

using test::Datagrams;
using test::fragment_all;
using test::make_cloud;
using test::make_info;
using test::put_le;
using test::reseal;
using Reassembler = StaticPointCloudReassembler<2, 4096, 64>;

Datagrams frame(std::uint32_t seq, std::size_t points = 1000, std::uint32_t sender = 0xA1B2C3D4u) {
  const auto cloud = make_cloud(points, 40.0f, seq);
  auto info = make_info(seq);
  info.sender_id = sender;
  Datagrams d;
  EXPECT_EQ(fragment_all(info, cloud.view(), d), CloudStatus::kOk);
  return d;
}

TEST(PointCloudFaults, LostFragmentTimesOutAndLateFragmentsAreStale) {
  ReassemblyConfig cfg;
  cfg.frame_timeout_ns = 100;
  auto r = std::make_unique<Reassembler>(cfg);
  const Datagrams d = frame(1);
  ASSERT_GE(d.size(), 3u);
  for (std::size_t i = 0; i + 1 < d.size(); ++i) EXPECT_EQ(r->push(d[i], 10), CloudStatus::kOk);
  EXPECT_EQ(r->frames_in_flight(), 1u);
  EXPECT_EQ(r->expire(110), 0u);  // not older than the timeout yet
  EXPECT_EQ(r->expire(111), 1u);
  EXPECT_EQ(r->counters().frames_timed_out, 1u);
  EXPECT_EQ(r->frames_in_flight(), 0u);
  EXPECT_EQ(r->push(d.back(), 120), CloudStatus::kStaleFrame);  // no zombie frame is started
  EXPECT_EQ(r->frames_in_flight(), 0u);
  EXPECT_EQ(r->counters().frames_completed, 0u);
}

TEST(PointCloudFaults, TruncatedDatagramsAreRejectedAtEveryLength) {
  auto r = std::make_unique<Reassembler>();
  const Datagrams d = frame(2);
  const auto& full = d[0];
  for (std::size_t len = 0; len < full.size(); ++len) {
    const std::span<const std::uint8_t> cut(full.data(), len);
    ASSERT_EQ(r->push(cut, 0), CloudStatus::kTruncated) << len;
  }
  EXPECT_EQ(r->counters().truncated, full.size());
  EXPECT_EQ(r->frames_in_flight(), 0u);
  std::vector<std::uint8_t> longer = full;
  longer.push_back(0);
  EXPECT_EQ(r->push(longer, 0), CloudStatus::kMalformed);  // trailing bytes are not ignored
}

TEST(PointCloudFaults, EverySingleBitFlipIsRejected) {
  auto r = std::make_unique<Reassembler>();
  const Datagrams d = frame(3);
  const auto& good = d[1];
  std::size_t bad_crc = 0;
  for (std::size_t byte = 0; byte < good.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      auto m = good;
      m[byte] = static_cast<std::uint8_t>(m[byte] ^ (1u << bit));
      const CloudStatus s = r->push(m, 0);
      ASSERT_NE(s, CloudStatus::kOk) << byte << ":" << bit;
      ASSERT_NE(s, CloudStatus::kFrameComplete);
      bad_crc += s == CloudStatus::kBadCrc ? 1 : 0;
    }
  }
  // Flips outside magic/version/header-size/payload-length fields are all caught by the CRC.
  EXPECT_GE(bad_crc, (good.size() - 10) * 8);
  EXPECT_EQ(r->frames_in_flight(), 0u);
}

TEST(PointCloudFaults, LyingHeadersBehindAValidCrcAreRejected) {
  auto r = std::make_unique<Reassembler>();
  const Datagrams d = frame(4);
  struct Lie {
    std::size_t offset;
    std::uint64_t value;
    int bytes;
    CloudStatus expected;
  };
  const Lie lies[] = {
      {20, 0xFFFF, 2, CloudStatus::kMalformed},           // fragment index beyond count
      {22, 0, 2, CloudStatus::kMalformed},                // zero fragments
      {22, 0xFFFF, 2, CloudStatus::kMalformed},           // count disagrees with total/per-fragment
      {96, 0xFFFFFFFFu, 4, CloudStatus::kMalformed},      // huge total, count no longer matches
      {92, 5, 2, CloudStatus::kMalformed},                // points disagree with payload
      {94, 0, 2, CloudStatus::kMalformed},                // zero points per fragment
      {88, 0xFFC00000u, 4, CloudStatus::kMalformed},      // NaN scale
      {88, 0, 4, CloudStatus::kMalformed},                // zero scale
      {32, 0x7FF0000000000000ull, 8, CloudStatus::kMalformed},  // infinite position
      {5, 9, 1, CloudStatus::kUnsupported},               // unknown message type
      {6, 0x8003, 2, CloudStatus::kUnsupported},          // unknown flag bit
  };
  for (const Lie& lie : lies) {
    auto m = d[0];
    put_le(m, lie.offset, lie.value, lie.bytes);
    reseal(m);
    EXPECT_EQ(r->push(m, 0), lie.expected) << "offset " << lie.offset;
  }
  // A consistent but huge frame (total and count agree) is refused by capacity, not by memory.
  auto big = d[0];
  put_le(big, 96, 65535u * 143u, 4);  // total points
  put_le(big, 22, 65535u, 2);         // fragment count
  reseal(big);
  EXPECT_EQ(r->push(big, 0), CloudStatus::kCapacityExceeded);
  EXPECT_EQ(r->frames_in_flight(), 0u);
  // Magic and version are checked before anything else.
  auto magic = d[0];
  magic[0] = 'X';
  EXPECT_EQ(r->push(magic, 0), CloudStatus::kBadMagic);
  auto version = d[0];
  version[4] = 2;
  reseal(version);
  EXPECT_EQ(r->push(version, 0), CloudStatus::kUnsupported);
}

TEST(PointCloudFaults, FragmentDisagreeingWithItsFrameIsInconsistent) {
  auto r = std::make_unique<Reassembler>();
  const Datagrams d = frame(5);
  EXPECT_EQ(r->push(d[0], 0), CloudStatus::kOk);
  auto other = d[1];
  put_le(other, 24, 42, 8);  // different timestamp, same key
  reseal(other);
  EXPECT_EQ(r->push(other, 1), CloudStatus::kInconsistent);
  EXPECT_EQ(r->counters().inconsistent, 1u);
  for (std::size_t i = 1; i < d.size(); ++i) r->push(d[i], 2);
  EXPECT_EQ(r->counters().frames_completed, 1u);
}

TEST(PointCloudFaults, OldestIncompleteFrameIsEvictedWhenSlotsRunOut) {
  auto r = std::make_unique<Reassembler>();  // 2 slots
  const Datagrams a = frame(10), b = frame(11), c = frame(12);
  EXPECT_EQ(r->push(a[0], 1), CloudStatus::kOk);
  EXPECT_EQ(r->push(b[0], 2), CloudStatus::kOk);
  EXPECT_EQ(r->push(c[0], 3), CloudStatus::kOk);  // evicts a (oldest)
  EXPECT_EQ(r->counters().frames_evicted, 1u);
  EXPECT_EQ(r->push(a[1], 4), CloudStatus::kStaleFrame);
  int completed = 0;
  for (std::size_t i = 1; i < c.size(); ++i) completed += r->push(c[i], 5) == CloudStatus::kFrameComplete;
  for (std::size_t i = 1; i < b.size(); ++i) completed += r->push(b[i], 6) == CloudStatus::kFrameComplete;
  EXPECT_EQ(completed, 2);
}

TEST(PointCloudFaults, FragmenterRejectsBadInputAndSmallBuffers) {
  const auto cloud = make_cloud(10, 1.0f, 1);
  PointCloudFragmenter f;
  auto info = make_info(1);
  info.scale_m = 0.0f;
  EXPECT_EQ(f.begin(info, cloud.view()), CloudStatus::kInvalidArgument);
  info.scale_m = NAN;
  EXPECT_EQ(f.begin(info, cloud.view()), CloudStatus::kInvalidArgument);
  std::vector<float> odd = {1.0f, 2.0f};
  EXPECT_EQ(f.begin(make_info(1), CloudPointsView{odd, {}, {}}), CloudStatus::kInvalidArgument);
  std::vector<std::uint8_t> short_intensity(3);
  EXPECT_EQ(f.begin(make_info(1), CloudPointsView{cloud.xyz, short_intensity, {}}), CloudStatus::kInvalidArgument);
  EXPECT_EQ(f.begin(make_info(1), cloud.view(), 110), CloudStatus::kBufferTooSmall);
  ASSERT_EQ(f.begin(make_info(1), cloud.view()), CloudStatus::kOk);
  std::uint8_t tiny[64];
  std::size_t written = 1;
  EXPECT_EQ(f.next(tiny, written), CloudStatus::kBufferTooSmall);
  EXPECT_EQ(written, 0u);
}

}  // namespace
}  // namespace v2xloc::protocol
