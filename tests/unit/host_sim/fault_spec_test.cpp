// The replay's fault specification (host_sim/replay/fault_injection.hpp): the lidar-blind keys
// parse strictly, describe themselves, and blind exactly the scans stamped inside the spell.
#include <gtest/gtest.h>

#include <string>

#include "host_sim/replay/fault_injection.hpp"

namespace v2xloc::sim::replay {
namespace {

TEST(FaultSpec, LidarBlindKeysParse) {
  FaultSpec f;
  std::string error;
  ASSERT_TRUE(parse_fault_spec("lidar-blind=3,lidar-blind-at=6.5", f, error)) << error;
  EXPECT_DOUBLE_EQ(f.lidar_blind_s, 3.0);
  EXPECT_DOUBLE_EQ(f.lidar_blind_at_s, 6.5);
  EXPECT_FALSE(f.lidar_blind_empty);
  EXPECT_TRUE(f.any());
  EXPECT_EQ(describe(f), "lidar-blind=3@6.5(no scans)");

  ASSERT_TRUE(parse_fault_spec("lidar-blind=0.5,lidar-blind-empty=1", f, error)) << error;
  EXPECT_DOUBLE_EQ(f.lidar_blind_at_s, 1.0);  // the default start
  EXPECT_TRUE(f.lidar_blind_empty);
  EXPECT_EQ(describe(f), "lidar-blind=0.5@1(empty scans)");

  ASSERT_TRUE(parse_fault_spec("none", f, error)) << error;
  EXPECT_FALSE(f.any());
  EXPECT_DOUBLE_EQ(f.lidar_blind_s, 0.0);
}

TEST(FaultSpec, BadLidarBlindValuesAreRefusedNamingTheKey) {
  for (const char* spec : {"lidar-blind=-1", "lidar-blind=abc", "lidar-blind=3s", "lidar-blind=", "lidar-blind",
                           "lidar-blind=nan", "lidar-blind-at=-2", "lidar-blind-at=1e7", "lidar-blind-empty=2",
                           "lidar-blind-empty=yes", "lidar-blind-empty="}) {
    FaultSpec f;
    f.seed = 77;
    std::string error;
    EXPECT_FALSE(parse_fault_spec(spec, f, error)) << spec;
    const std::string key = std::string(spec).substr(0, std::string(spec).find('='));
    EXPECT_EQ(error.rfind("bad value for fault '" + key + "'", 0), 0u) << spec << ": " << error;
    EXPECT_EQ(f.seed, 77u) << "a refused spec leaves the output alone: " << spec;
  }
  FaultSpec f;
  std::string error;
  EXPECT_FALSE(parse_fault_spec("lidar-blinded=3", f, error));
  EXPECT_EQ(error, "unknown fault 'lidar-blinded'");
}

TEST(FaultSpec, TheSpellBlindsTheScansStampedInsideIt) {
  FaultSpec f;
  std::string error;
  ASSERT_TRUE(parse_fault_spec("lidar-blind=3,lidar-blind-at=6", f, error)) << error;
  FaultInjector injector;
  injector.configure(f);
  EXPECT_FALSE(injector.lidar_blinded(5.9));
  EXPECT_TRUE(injector.lidar_blinded(6.0));  // the start is inside
  EXPECT_TRUE(injector.lidar_blinded(8.9));
  EXPECT_FALSE(injector.lidar_blinded(9.0));  // the end is not
  int blinded = 0;
  for (int i = 0; i < 200; ++i) blinded += injector.lidar_blinded(i * 0.1) ? 1 : 0;
  EXPECT_EQ(blinded, 30);  // 3 s of a 10 Hz LiDAR

  injector.configure(FaultSpec{});
  EXPECT_FALSE(injector.lidar_blinded(1.0));  // no spell by default
}

}  // namespace
}  // namespace v2xloc::sim::replay
