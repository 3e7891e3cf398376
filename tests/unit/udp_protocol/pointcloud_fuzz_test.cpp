// Mini fuzz loop (seeded, deterministic): random bytes and mutated valid fragments, with and
// without a re-sealed CRC, must never crash, overrun (ASan preset) or complete a bogus frame.
#include <gtest/gtest.h>

#include <memory>

#include "cloud_test_util.hpp"

namespace v2xloc::protocol {
namespace {

TEST(PointCloudFuzz, GarbageAndMutationsNeverBreakTheReassembler) {
  auto r = std::make_unique<StaticPointCloudReassembler<3, 3000, 32>>();
  test::Datagrams seeds;
  for (std::uint32_t seq = 0; seq < 3; ++seq) {
    const auto cloud = test::make_cloud(700 + 500 * seq, 50.0f, seq);
    ASSERT_EQ(test::fragment_all(test::make_info(seq), cloud.view(seq != 1, seq != 2), seeds), CloudStatus::kOk);
  }
  std::mt19937 rng(20261123);
  std::uint64_t completed = 0;
  constexpr int kIterations = 30000;
  for (int it = 0; it < kIterations; ++it) {
    std::vector<std::uint8_t> d;
    const unsigned mode = rng() % 4;
    if (mode == 0) {  // pure garbage, sometimes with a valid magic
      d.resize(rng() % 1500);
      for (auto& b : d) b = static_cast<std::uint8_t>(rng());
      if (d.size() >= 4 && (rng() & 1)) test::put_le(d, 0, pointcloud_wire::kMagic, 4);
    } else {  // mutate a valid fragment: flips, header field rewrites, truncation, extension
      d = seeds[rng() % seeds.size()];
      const unsigned edits = 1 + rng() % 4;
      for (unsigned e = 0; e < edits; ++e) {
        const std::size_t at = rng() % d.size();
        if (rng() % 3 == 0 && at < pointcloud_wire::kHeaderBytes) {
          d[at] = static_cast<std::uint8_t>(rng() % 4 == 0 ? 0xFF : rng());
        } else {
          d[at] = static_cast<std::uint8_t>(d[at] ^ (1u << (rng() % 8)));
        }
      }
      if (mode == 2 && d.size() > 8) d.resize(rng() % d.size());
      if (mode == 3 && d.size() >= pointcloud_wire::kHeaderBytes + 4) test::reseal(d);
    }
    const CloudStatus s = r->push(d, it);
    if (s == CloudStatus::kFrameComplete) {
      ++completed;
      const auto& c = r->completed();
      ASSERT_EQ(c.xyz.size(), 3u * c.point_count);
      ASSERT_LE(c.point_count, 3000u);
    }
    // Valid traffic keeps flowing between the garbage.
    if (it % 50 == 0) r->push(seeds[static_cast<std::size_t>(it / 50) % seeds.size()], it);
  }
  const auto& k = r->counters();
  std::printf("fuzz: %d datagrams, completed %llu, crc %llu, malformed %llu, truncated %llu, inconsistent %llu\n",
              kIterations, static_cast<unsigned long long>(completed), static_cast<unsigned long long>(k.bad_crc),
              static_cast<unsigned long long>(k.malformed), static_cast<unsigned long long>(k.truncated),
              static_cast<unsigned long long>(k.inconsistent));
  EXPECT_GT(k.bad_crc, 1000u);
  EXPECT_GT(k.truncated, 100u);
}

}  // namespace
}  // namespace v2xloc::protocol
