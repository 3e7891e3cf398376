// The lidar-blind fault end to end (host_sim/replay/fault_injection.hpp) on a short simulated turn
// through v2xloc-firmware: a silent LiDAR gets a pose every frame from the firmware's period timer
// (firmware/wire/period_timer.hpp), never flagged as a registration, and the replay and the
// evaluator keep every frame on its own recording frame and truth; a LiDAR sending scans without
// points gets a pose every frame too, with neither registration nor odometry in the spell. (The
// quick recording does not localize in 2 s: tracking through a spell is measured on the full
// recordings, tools/eval/imu_scenarios.py, and its rule in tests/unit/localization.)
#include <gtest/gtest.h>

#include <string>

#include "host_sim/replay/replay_session.hpp"
#include "tests/integration/e2e/generated_recording.hpp"
#include "tools/eval/firmware_run.hpp"

namespace v2xloc::sim::replay {
namespace {

const std::string kBin = test::kBinDir;
constexpr int kFrames = 20;
constexpr int kFirstBlind = 10, kBlind = 5;  // lidar-blind=0.5,lidar-blind-at=1: frames 10..14
const char* const kSpell = "lidar-blind=0.5,lidar-blind-at=1";

class LidarBlindE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    recording_ = new test::GeneratedRecording("v2xloc_blind_e2e", "--scenario 3 --perm 2_infra --quick --no-stereo");
  }
  static void TearDownTestSuite() { delete recording_; }
  void SetUp() override {
    ASSERT_TRUE(recording_->ok()) << "v2xloc-sim generate failed, see " << recording_->log();
    std::string error;
    ASSERT_TRUE(reader_.open(recording_->path(), error)) << error;
    ASSERT_GE(reader_.frame_count(), kFrames);
  }
  void replay(const std::string& faults, ReplayResult& result) {
    ReplayOptions options;
    options.firmware_path = kBin + "v2xloc-firmware";
    options.stream.max_frames = kFrames;
    std::string error;
    ASSERT_TRUE(parse_fault_spec(faults, options.stream.faults, error)) << error;
    ASSERT_TRUE(replay_recording(reader_, options, result, error)) << error << "\n" << result.firmware_output;
    EXPECT_EQ(result.firmware_exit_code, 0);
    EXPECT_EQ(result.timeouts, 0);
    EXPECT_EQ(result.stream_stats.faults.ego_scans_blinded, static_cast<std::uint64_t>(kBlind));
  }

  static test::GeneratedRecording* recording_;
  RecordingReader reader_;
};
test::GeneratedRecording* LidarBlindE2e::recording_ = nullptr;

// The spell's frames in the pose and diagnostic frames: the filter's prediction, never a registration.
void expect_predicted_in_spell(const ReplayResult& result, int first, int count) {
  for (int i = first; i < first + count; ++i) {
    const ReplayedFrame& f = result.frames[static_cast<std::size_t>(i)];
    EXPECT_FALSE(f.registration_position.attempted) << "frame " << i;
    EXPECT_FALSE(f.position.flags.registration_valid) << "frame " << i;
  }
}

TEST_F(LidarBlindE2e, ASilentLidarGetsAPoseEveryFrameFromThePeriodTimer) {
  ReplayResult result;
  replay(kSpell, result);
  EXPECT_EQ(result.frames_without_scan, kBlind);
  EXPECT_EQ(result.periods_without_scan, kBlind);
  EXPECT_EQ(result.frames_without_pose, 0);
  EXPECT_EQ(result.late_scans, 0);
  EXPECT_EQ(result.stream_stats.ego_scans, static_cast<std::size_t>(kFrames - kBlind));
  ASSERT_EQ(result.frames.size(), static_cast<std::size_t>(kFrames));
  for (std::size_t k = 0; k < result.frames.size(); ++k) {
    EXPECT_EQ(result.frames[k].frame, static_cast<int>(k));
    EXPECT_EQ(result.frames[k].attitude.frame_counter, k);  // one period per frame, with or without a scan
  }
  expect_predicted_in_spell(result, kFirstBlind, kBlind);
  EXPECT_NE(result.firmware_output.find("periods_without_scan 5 late_scans 0"), std::string::npos)
      << result.firmware_output;

  eval::FirmwareRunOptions options;
  options.firmware_path = kBin + "v2xloc-firmware";
  options.max_frames = kFrames;
  options.quiet = true;
  std::string error;
  ASSERT_TRUE(parse_fault_spec(kSpell, options.faults, error)) << error;
  std::vector<eval::FrameRecord> records;
  eval::RunStats stats;
  ASSERT_TRUE(eval::run_firmware(reader_, options, records, stats, error)) << error;
  EXPECT_EQ(stats.frames_without_pose, 0);
  ASSERT_EQ(records.size(), static_cast<std::size_t>(kFrames));
  const eval::FrameRecord& after = records[kFirstBlind + kBlind];  // the first pose after the spell
  EXPECT_DOUBLE_EQ(after.t, reader_.frame_time(kFirstBlind + kBlind));
  EXPECT_TRUE(after.truth.isApprox(reader_.ground_truth()[kFirstBlind + kBlind].pose));
  EXPECT_EQ(after.out.frame, static_cast<std::uint32_t>(kFirstBlind + kBlind));
}

TEST_F(LidarBlindE2e, ALidarSendingEmptyScansGetsAPoseEveryFrameWithoutRegistrationOrOdometry) {
  ReplayResult result;
  replay(std::string(kSpell) + ",lidar-blind-empty=1", result);
  EXPECT_EQ(result.frames_without_scan, 0);
  EXPECT_EQ(result.periods_without_scan, 0);
  ASSERT_EQ(result.frames.size(), static_cast<std::size_t>(kFrames));
  EXPECT_NE(result.firmware_output.find("ego_frames_held 0"), std::string::npos) << result.firmware_output;
  for (int i = 0; i < kFrames; ++i) {
    const ReplayedFrame& f = result.frames[static_cast<std::size_t>(i)];
    EXPECT_EQ(f.frame, i);
    if (i >= kFirstBlind && i < kFirstBlind + kBlind) {
      EXPECT_FALSE(f.registration_position.ok) << "frame " << i;
      EXPECT_FALSE(f.odometry_position.odometry_ok) << "frame " << i;
    }
  }
  expect_predicted_in_spell(result, kFirstBlind, kBlind);
  // Before the spell the quick recording's LiDAR does register and carry the odometry.
  EXPECT_TRUE(result.frames[kFirstBlind - 1].odometry_position.odometry_ok);
}

}  // namespace
}  // namespace v2xloc::sim::replay
