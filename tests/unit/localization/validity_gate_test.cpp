#include "v2xloc/algo/localization/validity_gate.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace v2xloc {
namespace {

// Series: good frames at f ~ 0.8, r ~ 0.05, one bad-fitness frame (3), one high-RMSE frame (7),
// one failed registration (10), and a NaN (12).
std::vector<GateSample> series() {
  std::vector<GateSample> s(15, GateSample{0.80, 0.050, true});
  s[1].fitness = 0.78;
  s[3].fitness = 0.60;
  s[5].rmse = 0.055;
  s[7].rmse = 0.090;
  s[10] = GateSample{0.95, 0.001, false};  // failed: must not shape the envelope
  s[12].fitness = std::nan("");
  return s;
}

TEST(ValidityGate, FixedLagCentredWindowExactFlags) {
  ValidityGateParams p;
  p.window = 5;  // radius 2
  p.fitness_margin = 0.05;
  p.rmse_margin = 0.02;
  FixedLagValidityGate gate(p);
  EXPECT_EQ(gate.lag(), 2u);
  const auto s = series();
  std::vector<int> flags(s.size(), -1);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const GateDecision d = gate.push(s[i]);
    if (i < 2) {
      EXPECT_FALSE(d.available);
      continue;
    }
    ASSERT_TRUE(d.available);
    EXPECT_EQ(d.frame, i - 2);
    flags[d.frame] = d.valid ? 1 : 0;
  }
  for (GateDecision d = gate.flush(); d.available; d = gate.flush()) flags[d.frame] = d.valid;
  const std::vector<int> expected = {1, 1, 1, 0, 1, 1, 1, 0, 1, 1, 0, 1, 0, 1, 1};
  EXPECT_EQ(flags, expected);
  EXPECT_EQ(gate.counters().decided, 15u);
  EXPECT_EQ(gate.counters().failed_registrations, 2u);
  EXPECT_EQ(gate.counters().low_fitness, 1u);
  EXPECT_EQ(gate.counters().high_rmse, 1u);
}

TEST(ValidityGate, EnvelopeUsesFutureFramesOnlyInFixedLag) {
  // A quality jump at frame 4: frames 2, 3 see the better future in the centred window and are
  // rejected; the causal gate accepts them (it cannot see the future) and rejects nothing.
  std::vector<GateSample> s(8, GateSample{0.50, 0.10, true});
  for (std::size_t i = 4; i < 8; ++i) s[i] = GateSample{0.90, 0.03, true};
  ValidityGateParams p;
  p.window = 5;
  FixedLagValidityGate lag(p);
  CausalValidityGate causal(p);
  std::vector<int> lag_flags(8, -1), causal_flags(8, -1);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const GateDecision d = lag.push(s[i]);
    if (d.available) lag_flags[d.frame] = d.valid;
    const GateDecision c = causal.push(s[i]);
    ASSERT_TRUE(c.available);
    EXPECT_EQ(c.frame, i);
    causal_flags[i] = c.valid;
  }
  for (GateDecision d = lag.flush(); d.available; d = lag.flush()) lag_flags[d.frame] = d.valid;
  EXPECT_EQ(lag_flags, (std::vector<int>{1, 1, 0, 0, 1, 1, 1, 1}));
  EXPECT_EQ(causal_flags, (std::vector<int>{1, 1, 1, 1, 1, 1, 1, 1}));
}

TEST(ValidityGate, CausalRejectsDropAfterGoodFrames) {
  std::vector<GateSample> s(6, GateSample{0.90, 0.03, true});
  s[3] = GateSample{0.70, 0.03, true};   // fitness drop
  s[5] = GateSample{0.90, 0.08, true};   // RMSE rise
  ValidityGateParams p;
  p.window = 3;  // radius 1: causal window [i-2, i]
  CausalValidityGate gate(p);
  std::vector<int> flags;
  for (const auto& x : s) flags.push_back(gate.push(x).valid);
  EXPECT_EQ(flags, (std::vector<int>{1, 1, 1, 0, 1, 0}));
  EXPECT_EQ(gate.counters().valid, 4u);
}

TEST(ValidityGate, WindowClampedToCapacityAndLongRunStaysInRing) {
  ValidityGateParams p;
  p.window = 1000;
  FixedLagValidityGate gate(p);
  EXPECT_EQ(gate.params().window, config::kGateMaxWindow);
  std::size_t decided = 0;
  for (int i = 0; i < 500; ++i) {
    GateSample s{0.8 + 0.001 * (i % 7), 0.05, true};
    if (gate.push(s).available) ++decided;
  }
  EXPECT_EQ(decided, 500 - gate.lag());
}

}  // namespace
}  // namespace v2xloc
