// Round trips through the fragmenter and reassembler: layout, quantization error, ordering.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "cloud_test_util.hpp"

namespace v2xloc::protocol {
namespace {

using test::Datagrams;
using test::fragment_all;
using test::make_cloud;
using test::make_info;
using Reassembler = StaticPointCloudReassembler<4, 20000, 256>;

// Reassembles `datagrams` in the given order; returns the number of completed frames.
int feed(PointCloudReassembler& r, const Datagrams& datagrams, std::vector<float>* xyz = nullptr,
         std::vector<std::uint8_t>* intensity = nullptr, std::vector<std::uint16_t>* time_ticks = nullptr,
         CloudFrameInfo* info = nullptr) {
  int completed = 0;
  std::int64_t now = 1000;
  for (const auto& d : datagrams) {
    const CloudStatus s = r.push(d, now++);
    if (s == CloudStatus::kFrameComplete) {
      ++completed;
      const ReassembledCloud& c = r.completed();
      if (xyz) xyz->assign(c.xyz.begin(), c.xyz.end());
      if (intensity) intensity->assign(c.intensity.begin(), c.intensity.end());
      if (time_ticks) time_ticks->assign(c.time_offset_ticks.begin(), c.time_offset_ticks.end());
      if (info) *info = c.info;
    }
  }
  return completed;
}

TEST(PointCloudUdp, HeaderBytesAreLittleEndianAtDocumentedOffsets) {
  const auto cloud = make_cloud(3, 10.0f, 1);
  Datagrams d;
  ASSERT_EQ(fragment_all(make_info(0x01020304u), cloud.view(), d), CloudStatus::kOk);
  ASSERT_EQ(d.size(), 1u);
  const auto& b = d[0];
  EXPECT_EQ(b[0], 'V');
  EXPECT_EQ(b[1], '2');
  EXPECT_EQ(b[2], 'X');
  EXPECT_EQ(b[3], 'P');
  EXPECT_EQ(b[4], 1);                                     // version
  EXPECT_EQ(b[5], 2);                                     // map share
  EXPECT_EQ(test::get_le(b, 6, 2), 0x3u);                 // intensity | point time
  EXPECT_EQ(test::get_le(b, 8, 2), 104u);                 // header bytes
  EXPECT_EQ(test::get_le(b, 10, 2), 7u);                  // sensor id
  EXPECT_EQ(test::get_le(b, 12, 4), 0xA1B2C3D4u);         // sender id
  EXPECT_EQ(b[16], 0x04);                                 // frame seq, LSB first
  EXPECT_EQ(b[19], 0x01);
  EXPECT_EQ(test::get_le(b, 22, 2), 1u);                  // fragment count
  EXPECT_EQ(test::get_le(b, 24, 8), 1'700'000'000'123'456'789ull);
  EXPECT_EQ(test::get_le(b, 96, 4), 3u);                  // total points
  EXPECT_EQ(test::get_le(b, 100, 2), 3u * 9u);            // payload bytes
  EXPECT_EQ(b.size(), 104u + 27u + 4u);
}

TEST(PointCloudUdp, Int16RoundTripStaysWithinHalfAStep) {
  const auto cloud = make_cloud(10000, 60.0f, 42);
  const auto info = make_info(5);
  Datagrams d;
  PointCloudFragmenter f;
  ASSERT_EQ(fragment_all(info, cloud.view(), d, &f), CloudStatus::kOk);
  EXPECT_EQ(f.point_stride_bytes(), 9u);
  EXPECT_EQ(f.points_per_fragment(), (1400u - 108u) / 9u);
  EXPECT_EQ(d.size(), (10000u + f.points_per_fragment() - 1) / f.points_per_fragment());
  for (const auto& g : d) EXPECT_LE(g.size(), 1400u);

  auto r = std::make_unique<Reassembler>();
  std::vector<float> xyz;
  std::vector<std::uint8_t> intensity;
  std::vector<std::uint16_t> time_ticks;
  CloudFrameInfo got{};
  ASSERT_EQ(feed(*r, d, &xyz, &intensity, &time_ticks, &got), 1);
  ASSERT_EQ(xyz.size(), cloud.xyz.size());
  EXPECT_EQ(intensity, cloud.intensity);
  EXPECT_EQ(time_ticks, cloud.time_ticks);
  double max_err = 0.0;
  for (std::size_t i = 0; i < xyz.size(); ++i) max_err = std::max(max_err, std::abs(double(xyz[i]) - double(cloud.xyz[i])));
  // Bound: half a quantization step (1 mm) plus the float rounding of a 65 m value (~4 um).
  EXPECT_LE(max_err, 0.001 + 65.0 * 0x1p-23);
  EXPECT_GT(max_err, 0.0009);  // the bound is tight: uniform inputs reach it
  std::printf("int16 @ 2 mm: %zu fragments, max abs error %.6f m\n", d.size(), max_err);
  EXPECT_EQ(got.sender_id, info.sender_id);
  EXPECT_EQ(got.sensor_id, info.sensor_id);
  EXPECT_EQ(got.frame_seq, info.frame_seq);
  EXPECT_EQ(got.timestamp_ns, info.timestamp_ns);
  EXPECT_EQ(got.type, info.type);
  EXPECT_EQ(got.width, CoordWidth::kInt16);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(got.pose.position_m[i], info.pose.position_m[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(got.pose.quaternion_xyzw[i], info.pose.quaternion_xyzw[i]);
  EXPECT_EQ(r->counters().frames_completed, 1u);
  EXPECT_EQ(r->frames_in_flight(), 0u);
}

TEST(PointCloudUdp, Int32RoundTripCoversKilometres) {
  const auto cloud = make_cloud(3000, 5000.0f, 7);
  const auto info = make_info(9, CoordWidth::kInt32, 0.0001f);
  Datagrams d;
  PointCloudFragmenter f;
  ASSERT_EQ(fragment_all(info, cloud.view(false, false), d, &f), CloudStatus::kOk);
  EXPECT_EQ(f.point_stride_bytes(), 12u);
  EXPECT_EQ(f.dropped_out_of_range(), 0u);
  auto r = std::make_unique<Reassembler>();
  std::vector<float> xyz;
  std::vector<std::uint8_t> intensity{1};
  std::vector<std::uint16_t> time_ticks{1};
  ASSERT_EQ(feed(*r, d, &xyz, &intensity, &time_ticks), 1);
  EXPECT_TRUE(intensity.empty());
  EXPECT_TRUE(time_ticks.empty());
  ASSERT_EQ(xyz.size(), cloud.xyz.size());
  for (std::size_t i = 0; i < xyz.size(); ++i) {
    const double bound = 0.00005 + std::abs(double(cloud.xyz[i])) * 0x1p-23 + 1e-9;
    ASSERT_LE(std::abs(double(xyz[i]) - double(cloud.xyz[i])), bound) << i;
  }
}

TEST(PointCloudUdp, OutOfRangeAndNonFinitePointsAreDroppedAndCounted) {
  std::vector<float> xyz = {1.0f, 2.0f, 3.0f,   70.0f, 0.0f, 0.0f,   NAN, 0.0f, 0.0f,
                            -65.534f, 65.534f, 0.0f,   0.0f, INFINITY, 0.0f,   0.0f, 0.0f, -65.6f};
  std::vector<std::uint8_t> intensity = {10, 20, 30, 40, 50, 60};
  PointCloudFragmenter f;
  ASSERT_EQ(f.begin(make_info(1), CloudPointsView{xyz, intensity, {}}), CloudStatus::kOk);
  EXPECT_EQ(f.total_points(), 2u);
  EXPECT_EQ(f.dropped_out_of_range(), 2u);
  EXPECT_EQ(f.dropped_non_finite(), 2u);
  Datagrams d;
  ASSERT_EQ(fragment_all(make_info(1), CloudPointsView{xyz, intensity, {}}, d), CloudStatus::kOk);
  auto r = std::make_unique<Reassembler>();
  std::vector<float> got;
  std::vector<std::uint8_t> got_i;
  ASSERT_EQ(feed(*r, d, &got, &got_i), 1);
  ASSERT_EQ(got.size(), 6u);
  EXPECT_NEAR(got[3], -65.534f, 0.001f);
  EXPECT_EQ(got_i, (std::vector<std::uint8_t>{10, 40}));
}

TEST(PointCloudUdp, EmptyFrameIsOneFragment) {
  Datagrams d;
  ASSERT_EQ(fragment_all(make_info(3), CloudPointsView{}, d), CloudStatus::kOk);
  ASSERT_EQ(d.size(), 1u);
  auto r = std::make_unique<Reassembler>();
  EXPECT_EQ(r->push(d[0], 0), CloudStatus::kFrameComplete);
  EXPECT_EQ(r->completed().point_count, 0u);
}

TEST(PointCloudUdp, ReorderedAndDuplicatedFragmentsGiveTheSameFrame) {
  const auto cloud = make_cloud(5000, 50.0f, 3);
  Datagrams d;
  ASSERT_EQ(fragment_all(make_info(11), cloud.view(), d), CloudStatus::kOk);
  auto r = std::make_unique<Reassembler>();
  std::vector<float> in_order;
  ASSERT_EQ(feed(*r, d, &in_order), 1);

  Datagrams shuffled = d;
  for (std::size_t i = 0; i < d.size(); i += 3) shuffled.push_back(d[i]);  // duplicates
  std::mt19937 rng(99);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  r->reset();
  std::vector<float> reordered;
  ASSERT_EQ(feed(*r, shuffled, &reordered), 1);
  EXPECT_EQ(reordered, in_order);
  // Duplicates that arrive before completion count as duplicates, after it as stale.
  EXPECT_EQ(r->counters().duplicates + r->counters().stale_fragments, (d.size() + 2) / 3);
  EXPECT_EQ(r->counters().fragments_accepted, d.size());
}

TEST(PointCloudUdp, InterleavedFramesFromSeveralSendersReassembleIndependently) {
  auto r = std::make_unique<Reassembler>();
  const auto a = make_cloud(1500, 40.0f, 21);
  const auto b = make_cloud(900, 40.0f, 22);
  auto info_a = make_info(100);
  auto info_b = make_info(100);  // same sequence number, other sender: a different frame
  info_b.sender_id = 0x55u;
  Datagrams da, db, mixed;
  ASSERT_EQ(fragment_all(info_a, a.view(), da), CloudStatus::kOk);
  ASSERT_EQ(fragment_all(info_b, b.view(), db), CloudStatus::kOk);
  for (std::size_t i = 0; i < std::max(da.size(), db.size()); ++i) {
    if (i < da.size()) mixed.push_back(da[i]);
    if (i < db.size()) mixed.push_back(db[i]);
  }
  std::vector<std::uint32_t> senders;
  std::vector<std::uint32_t> counts;
  std::int64_t now = 0;
  for (const auto& g : mixed) {
    if (r->push(g, now++) == CloudStatus::kFrameComplete) {
      senders.push_back(r->completed().info.sender_id);
      counts.push_back(r->completed().point_count);
    }
  }
  EXPECT_EQ(senders, (std::vector<std::uint32_t>{0x55u, 0xA1B2C3D4u}));
  EXPECT_EQ(counts, (std::vector<std::uint32_t>{900u, 1500u}));
}

TEST(PointCloudUdp, MaxSizeFrameFillsTheCapacityExactly) {
  using Small = StaticPointCloudReassembler<1, 2000, 16>;
  auto r = std::make_unique<Small>();
  const auto exact = make_cloud(2000, 30.0f, 5);
  Datagrams d;
  ASSERT_EQ(fragment_all(make_info(1), exact.view(), d), CloudStatus::kOk);
  ASSERT_LE(d.size(), 16u);
  std::vector<float> got;
  EXPECT_EQ(feed(*r, d, &got), 1);
  EXPECT_EQ(got.size(), 6000u);

  EXPECT_EQ(r->counters().points_thinned, 0u);
}

// A cloud over the capacity arrives evenly thinned to it, whatever the fragment order: the
// points kept are those a full-size reassembler receives at the selected indices (point i when
// floor(i * kept / total) steps up), the sweep's whole extent, and the rest is counted.
TEST(PointCloudUdp, CloudOverTheCapacityIsThinnedEvenlyNotCut) {
  for (const std::size_t total : {2001u, 3500u}) {
    const auto cloud = make_cloud(total, 30.0f, 5);
    Datagrams d;
    ASSERT_EQ(fragment_all(make_info(2), cloud.view(), d), CloudStatus::kOk);
    std::vector<float> full;
    auto big = std::make_unique<StaticPointCloudReassembler<1, 4000, 32>>();
    ASSERT_EQ(feed(*big, d, &full), 1);
    ASSERT_EQ(full.size(), 3 * total);

    std::reverse(d.begin(), d.end());
    auto small = std::make_unique<StaticPointCloudReassembler<1, 2000, 32>>();
    std::vector<float> got;
    ASSERT_EQ(feed(*small, d, &got), 1) << total;
    ASSERT_EQ(got.size(), 6000u);
    EXPECT_EQ(small->completed().points_thinned, total - 2000);
    EXPECT_EQ(small->counters().points_thinned, total - 2000);
    EXPECT_EQ(small->counters().over_capacity, 0u);
    std::vector<float> expected;
    for (std::uint64_t i = 0; i < total; ++i) {
      if ((i + 1) * 2000 / total == i * 2000 / total) continue;
      for (int a = 0; a < 3; ++a) expected.push_back(full[3 * i + a]);
    }
    EXPECT_EQ(got, expected) << total;
    EXPECT_EQ(got[got.size() - 1], full[full.size() - 1]);  // the last point sent is kept
  }
}

TEST(PointCloudUdp, SmallerDatagramLimitIsHonoured) {
  const auto cloud = make_cloud(1000, 20.0f, 8);
  Datagrams d;
  PointCloudFragmenter f;
  ASSERT_EQ(fragment_all(make_info(4), cloud.view(), d, &f, 576), CloudStatus::kOk);
  for (const auto& g : d) EXPECT_LE(g.size(), 576u);
  auto r = std::make_unique<Reassembler>();
  std::vector<float> got;
  EXPECT_EQ(feed(*r, d, &got), 1);
  EXPECT_EQ(got.size(), cloud.xyz.size());
}

}  // namespace
}  // namespace v2xloc::protocol
