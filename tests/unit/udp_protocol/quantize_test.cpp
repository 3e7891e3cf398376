// The fragmenter's exact shortcuts against what they replace: round_half_away() against
// std::round, and the range check by largest_quantizable() against quantize_coordinate().
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "cloud_test_util.hpp"
#include "firmware/protocol/pointcloud_udp.hpp"
#include "firmware/protocol/round_half_away.hpp"

namespace v2xloc::protocol {
namespace {

void expect_same_as_std_round(double x) {
  ASSERT_EQ(std::bit_cast<std::uint64_t>(round_half_away(x)), std::bit_cast<std::uint64_t>(std::round(x)))
      << std::hexfloat << x;
}

TEST(RoundHalfAway, BitIdenticalToStdRoundOnEdgeCases) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> edges = {0.0, 0.5, 1.5, 2.5, 0.49999999999999994, 0.5000000000000001, 1.0, 0x1p52,
                               0x1p52 - 0.5, 0x1p52 - 1.0, 0x1p52 + 1.0, 0x1p53, 0x1p53 + 2.0, 0x1p63, 0x1p64,
                               4503599627370495.5, 2147483647.5, 2147483646.5, 32767.5, 32766.5, 1e300,
                               std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
                               std::numeric_limits<double>::denorm_min(), inf,
                               std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::signaling_NaN()};
  for (int k = -60; k <= 60; ++k) edges.push_back(std::ldexp(1.0, k));
  for (double v = 0.0; v < 40.0; v += 0.25) edges.push_back(v);
  for (const double e : edges) {
    for (const double x : {e, -e, std::nextafter(e, inf), std::nextafter(e, -inf), -std::nextafter(e, inf),
                           -std::nextafter(e, -inf)}) {
      expect_same_as_std_round(x);
    }
  }
}

TEST(RoundHalfAway, BitIdenticalToStdRoundOnRandomValues) {
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> small(-70000.0, 70000.0);
  for (int k = 0; k < 1'000'000; ++k) {
    expect_same_as_std_round(std::bit_cast<double>(rng()));  // every exponent, NaN payloads included
    const double s = small(rng);
    expect_same_as_std_round(s);
    expect_same_as_std_round(std::floor(s) + 0.5);  // exact ties
  }
}

// The fragmenter's division: a float coordinate over a float scale, in double.
TEST(RoundHalfAway, BitIdenticalOnQuantizationQuotients) {
  std::mt19937 rng(15);
  for (const float scale : {0.002f, 0.001f, 0.01f, 0.0005f, 0.1f, 1.0f}) {
    for (int k = 0; k < 300'000; ++k) {
      const float v = std::bit_cast<float>(static_cast<std::uint32_t>(rng()));
      expect_same_as_std_round(static_cast<double>(v) / static_cast<double>(scale));
    }
    // Exact ties: values that are an odd number of half steps.
    for (int h = -200001; h <= 200001; h += 2) {
      const float v = static_cast<float>(h * 0.5 * scale);
      expect_same_as_std_round(static_cast<double>(v) / static_cast<double>(scale));
    }
  }
}

TEST(LargestQuantizable, RangeCheckAgreesWithQuantizeCoordinate) {
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> scale_dist(1e-4f, 0.5f);
  std::vector<float> scales = {0.002f, 0.001f, 1.0f, 3e-7f, 1e30f, std::numeric_limits<float>::denorm_min()};
  for (int k = 0; k < 40; ++k) scales.push_back(scale_dist(rng));
  for (const float scale : scales) {
    for (const CoordWidth width : {CoordWidth::kInt16, CoordWidth::kInt32}) {
      const float m = largest_quantizable(scale, width);
      std::int32_t q = 0;
      auto agrees = [&](float v) {
        const bool by_range = std::isfinite(v) && std::fabs(v) <= m;
        ASSERT_EQ(quantize_coordinate(v, scale, width, q), by_range) << v << " scale " << scale;
        // The fragmenter's integer rounding of an accepted coordinate.
        if (by_range) {
          ASSERT_EQ(round_half_away_to_integer(static_cast<double>(v) / scale), q) << v;
        }
      };
      // Both sides of the edge, both signs, then random bit patterns and random values near it.
      for (const float e : {m, std::nextafter(m, 0.0f), std::nextafter(m, 1e38f), 0.0f, 1e38f}) {
        agrees(e);
        agrees(-e);
      }
      for (int i = 0; i < 20000; ++i) {
        agrees(std::bit_cast<float>(static_cast<std::uint32_t>(rng())));
        agrees(m * std::uniform_real_distribution<float>(-1.01f, 1.01f)(rng));
      }
    }
  }
}

// The payload bytes as the fragmenter wrote them before it quantized each point once: every
// coordinate through std::round, a point sent only when all three fit.
std::vector<std::uint8_t> reference_payload(const test::SyntheticCloud& c, float scale, CoordWidth width) {
  const double limit = width == CoordWidth::kInt16 ? 32767.0 : 2147483647.0;
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < c.xyz.size() / 3; ++i) {
    std::int64_t q[3];
    bool ok = true;
    for (int a = 0; a < 3; ++a) {
      const float v = c.xyz[3 * i + a];
      const double steps = std::round(static_cast<double>(v) / static_cast<double>(scale));
      ok = ok && std::isfinite(v) && steps <= limit && steps >= -limit;
      q[a] = ok ? static_cast<std::int64_t>(steps) : 0;
    }
    if (!ok) continue;
    for (const std::int64_t v : q) {
      for (int b = 0; b < (width == CoordWidth::kInt16 ? 2 : 4); ++b) out.push_back(static_cast<std::uint8_t>(v >> (8 * b)));
    }
    out.push_back(c.intensity[i]);
    out.push_back(static_cast<std::uint8_t>(c.time_ticks[i]));
    out.push_back(static_cast<std::uint8_t>(c.time_ticks[i] >> 8));
  }
  return out;
}

TEST(Fragmenter, PayloadBytesEqualTheStdRoundEncoding) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (const CoordWidth width : {CoordWidth::kInt16, CoordWidth::kInt32}) {
    for (const float scale : {0.002f, 0.001f, 0.0137f}) {
      // Coordinates across and beyond the int16 range, with ties, edges, NaN and inf mixed in.
      test::SyntheticCloud c = test::make_cloud(5000, 80.0f, 17);
      const float m = largest_quantizable(scale, width);
      const float specials[] = {nan, inf, -inf, m, -m, std::nextafter(m, inf), -std::nextafter(m, inf),
                                0.5f * scale, -0.5f * scale, 1.5f * scale, -2.5f * scale, -0.0f};
      for (std::size_t k = 0; k < c.xyz.size(); k += 7) c.xyz[k] = specials[(k / 7) % std::size(specials)];
      test::Datagrams datagrams;
      PointCloudFragmenter used;
      ASSERT_EQ(test::fragment_all(test::make_info(1, width, scale), c.view(), datagrams, &used), CloudStatus::kOk);
      std::vector<std::uint8_t> payload;
      for (const auto& d : datagrams) {
        payload.insert(payload.end(), d.begin() + pointcloud_wire::kHeaderBytes, d.end() - pointcloud_wire::kTrailerBytes);
      }
      const std::vector<std::uint8_t> expected = reference_payload(c, scale, width);
      EXPECT_EQ(payload, expected);
      EXPECT_EQ(used.total_points(), expected.size() / used.point_stride_bytes());
      EXPECT_GT(used.dropped_non_finite(), 0u);
      if (width == CoordWidth::kInt16) {
        EXPECT_GT(used.dropped_out_of_range(), 0u);
      }
    }
  }
}

}  // namespace
}  // namespace v2xloc::protocol
