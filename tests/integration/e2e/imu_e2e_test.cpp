// The IMU path end to end on a short simulated turn with an IMU: v2xloc-firmware (emulated HID
// device fed the recording's reports) and the in-process paths (the replay's offline wire path and
// the evaluator's) hand the localizer the same IMU samples in the same order (the period driver's
// digest, the localizer's counts); every report read is counted in the firmware's exit report;
// in every period the samples follow the period's CAN inputs and precede its map clouds and scan,
// in strictly increasing time; with the IMU faults the same holds and the losses are counted.
#include <gtest/gtest.h>


#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "firmware/app/configure_localizer.hpp"
#include "host_sim/replay/event_stream.hpp"
#include "host_sim/replay/replay_session.hpp"
#include "tests/integration/e2e/generated_recording.hpp"
#include "tools/eval/offline_run.hpp"

namespace v2xloc::sim::replay {
namespace {

const std::string kBin = test::kBinDir;
constexpr int kFrames = 15;

Localizer g_localizer;

// Every localizer input in order: v vehicle, g GNSS, i IMU, m map cloud, w period work, e scan.
class CallTap final : public LocalizerInputTap {
 public:
  void vehicle(const VehicleInput&) override { calls += 'v'; }
  void gnss(const GnssInput&) override { calls += 'g'; }
  void imu(const ImuInput& s) override {
    calls += 'i';
    if (imu_count > 0 && !(s.t > last_imu_t)) ++imu_not_increasing;
    last_imu_t = s.t;
    ++imu_count;
    digest = firmware::imu_digest_step(digest, s);
  }
  void map_cloud(const MapCloudInput&) override { calls += 'm'; }
  void period_work(double) override { calls += 'w'; }
  void ego_scan(const EgoScanInput& e) override {
    calls += 'e';
    if (imu_count > 0 && last_imu_t > e.t) ++imu_after_scan;
  }
  std::string calls;
  std::uint64_t digest = firmware::kImuDigestStart;
  std::uint64_t imu_count = 0, imu_not_increasing = 0, imu_after_scan = 0;
  double last_imu_t = 0.0;
};

// In each period (ending at a scan) the IMU samples come after the CAN inputs and before the map
// clouds and the scan: v/g* i* m* w? e.
bool periods_in_order(const std::string& calls) {
  int phase = 0;  // 0 CAN, 1 IMU, 2 map, 3 work
  for (const char c : calls) {
    const int p = c == 'v' || c == 'g' ? 0 : c == 'i' ? 1 : c == 'm' ? 2 : 3;
    if (c == 'e') {
      phase = 0;
      continue;
    }
    if (p < phase) return false;
    phase = p;
  }
  return true;
}

std::string imu_counts_line(const firmware::ImuCounters& i) {
  char line[256];
  std::snprintf(line, sizeof line, "imu reports %llu decoded %llu handed %llu lost %llu repeated %llu out_of_order %llu"
                " saturated %llu rejected %llu ", (unsigned long long)i.reports, (unsigned long long)i.samples,
                (unsigned long long)i.handed, (unsigned long long)i.lost, (unsigned long long)i.repeated,
                (unsigned long long)i.out_of_order, (unsigned long long)i.saturated, (unsigned long long)i.rejected());
  return line;
}

std::string localizer_line(std::uint64_t handed, std::uint64_t digest, const LocalizerCounters& l) {
  char line[160];
  std::snprintf(line, sizeof line, "imu to the localizer %llu (digest %016llx), received %u invalid %u",
                (unsigned long long)handed, (unsigned long long)digest, l.imu_received, l.imu_invalid);
  return line;
}

class ImuE2e : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    recording_ = new test::GeneratedRecording("v2xloc_imu_e2e", "--scenario 3 --perm 2_infra --quick --no-stereo");
  }
  static void TearDownTestSuite() { delete recording_; }
  void SetUp() override {
    ASSERT_TRUE(recording_->ok()) << "v2xloc-sim generate failed, see " << recording_->log();
    std::string error;
    ASSERT_TRUE(reader_.open(recording_->path(), error)) << error;
    ASSERT_FALSE(reader_.imu_reports_path().empty()) << "recording without IMU reports";
  }

  // The replay through the firmware and the offline wire path, both with `faults`; checks that
  // they agree on every IMU count and on the samples, and returns the offline decoder's counts.
  void run_both(const std::string& faults, firmware::ImuCounters& counts, ReplayResult& replayed) {
    ReplayOptions options;
    options.firmware_path = kBin + "v2xloc-firmware";
    options.stream.max_frames = kFrames;
    std::string error;
    ASSERT_TRUE(parse_fault_spec(faults, options.stream.faults, error)) << error;
    ASSERT_TRUE(replay_recording(reader_, options, replayed, error)) << error << "\n" << replayed.firmware_output;
    EXPECT_EQ(replayed.firmware_exit_code, 0);
    EXPECT_NE(replayed.firmware_output.find("heap allocations in the main loop: 0 "), std::string::npos)
        << replayed.firmware_output;

    auto decoder = std::make_unique<firmware::InputDecoder>();
    firmware::configure_localizer(g_localizer, make_geodetic_origin(reader_.origin_lat_deg(), reader_.origin_lon_deg(),
                                                                    reader_.origin_alt_m()));
    CallTap tap;
    int frames = 0;
    ASSERT_TRUE(run_offline(reader_, g_localizer, *decoder, options.stream, [&](const DecodedFrame&) { ++frames; }, error,
                            &tap))
        << error;
    EXPECT_EQ(frames, kFrames);
    counts = decoder->imu().counters();
    // The firmware handed the localizer the same samples, in the same order, and counted the same.
    EXPECT_NE(replayed.firmware_output.find(localizer_line(tap.imu_count, tap.digest, g_localizer.counters())),
              std::string::npos)
        << localizer_line(tap.imu_count, tap.digest, g_localizer.counters()) << "\n" << replayed.firmware_output;
    EXPECT_NE(replayed.firmware_output.find(imu_counts_line(counts)), std::string::npos)
        << imu_counts_line(counts) << "\n" << replayed.firmware_output;
    // Every report delivered was read and lands in exactly one count; none is left waiting.
    EXPECT_EQ(counts.reports, replayed.stream_stats.imu_reports);
    EXPECT_EQ(counts.reports, counts.samples + counts.rejected());
    EXPECT_EQ(counts.handed, counts.samples);
    EXPECT_EQ(tap.imu_count, counts.handed);
    EXPECT_EQ(g_localizer.counters().imu_received, counts.handed);
    EXPECT_TRUE(periods_in_order(tap.calls)) << tap.calls;
    EXPECT_EQ(tap.imu_not_increasing, 0u);
    EXPECT_EQ(tap.imu_after_scan, 0u);
  }

  static test::GeneratedRecording* recording_;
  RecordingReader reader_;
};
test::GeneratedRecording* ImuE2e::recording_ = nullptr;

TEST_F(ImuE2e, FirmwareDecodesEveryReportAndFeedsTheSameSamplesAsInProcess) {
  firmware::ImuCounters counts;
  ReplayResult replayed;
  run_both("none", counts, replayed);
  // 200 Hz: the reports received by the last frame's stamp (1.4 s), none lost or refused.
  EXPECT_GE(counts.reports, 270u);
  EXPECT_EQ(counts.lost + counts.rejected() + counts.saturated + counts.unsynced, 0u);
  EXPECT_NE(replayed.firmware_output.find("IMU: emulated HID device"), std::string::npos);

  // The evaluator's in-process port (full-precision clouds) feeds the localizer the same IMU calls.
  eval::RunOptions options;
  options.max_frames = kFrames;
  options.quiet = true;
  std::vector<eval::FrameRecord> records;
  eval::RunStats stats;
  std::string error;
  ASSERT_TRUE(eval::run_offline(reader_, g_localizer, options, records, stats, error)) << error;
  EXPECT_EQ(stats.counters.imu_received, counts.handed);
  EXPECT_EQ(stats.counters.imu_invalid, 0u);
}

TEST_F(ImuE2e, ImuFaultsAreCountedAlikeThroughTheFirmwareAndInProcess) {
  firmware::ImuCounters counts;
  ReplayResult replayed;
  run_both("seed=3,imu-dropout=0.3,imu-dropout-at=0.5,imu-repeat=0.05,imu-reorder=0.05,imu-stuck=gz,imu-stuck-at=1.1,"
           "imu-bias-step=2,imu-bias-step-at=0.9",
           counts, replayed);
  const ImuFaultStats& injected = replayed.stream_stats.faults.imu;
  EXPECT_EQ(injected.dropped, 60u);  // 0.3 s at 200 Hz
  EXPECT_GT(injected.repeated, 0u);
  EXPECT_GT(injected.reordered, 0u);
  EXPECT_GT(injected.stuck, 0u);
  EXPECT_GT(injected.biased, 0u);
  EXPECT_GE(counts.lost, injected.dropped);
  EXPECT_GT(counts.repeated, 0u);      // the transport's repeats
  EXPECT_GT(counts.out_of_order, 0u);  // the reports held back behind their successor
  EXPECT_EQ(counts.time_rejected, 0u);
  EXPECT_NE(replayed.firmware_output.find("ego_frames_held 0"), std::string::npos);  // a pose every frame
}

TEST_F(ImuE2e, ARecordingWithoutTheImuStreamRunsWithoutAnImu) {
  ReplayOptions options;
  options.firmware_path = kBin + "v2xloc-firmware";
  options.stream.max_frames = 3;
  options.stream.imu = false;
  ReplayResult replayed;
  std::string error;
  ASSERT_TRUE(replay_recording(reader_, options, replayed, error)) << error << "\n" << replayed.firmware_output;
  EXPECT_EQ(replayed.stream_stats.imu_reports, 0u);
  EXPECT_EQ(replayed.firmware_output.find("IMU: emulated HID device"), std::string::npos);
  EXPECT_NE(replayed.firmware_output.find("imu reports 0 decoded 0 handed 0 lost 0"), std::string::npos)
      << replayed.firmware_output;
}

}  // namespace
}  // namespace v2xloc::sim::replay
