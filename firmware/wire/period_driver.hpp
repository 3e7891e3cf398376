// One localizer period, for every caller: the firmware application, the replay's in-process wire
// path and the in-process evaluator feed it the same decoded inputs and get the same decisions.
// Callers own only their transport (where bytes come from, where the frames go).
//
// The period (the input order; firmware/wire/input_decoder.hpp):
//   1. CAN frames as they arrive: decoded, a vehicle input or a closed GNSS fix held in arrival
//      order (PendingInputs), nothing reaches the localizer yet;
//   2. HID IMU reports as they are read: decoded and queued (ImuInputDecoder), nothing reaches the
//      localizer yet;
//   3. clouds as they complete: a map share is admitted to the decoder's verification queue
//      (signer, sender id, surveyed pose, replay) and nothing reaches the map yet;
//   4. an ego scan (used or refused for its time stamp) closes the period: the held CAN inputs go to
//      the localizer first in arrival order, each preceded by the queued IMU samples older than it
//      (then the remaining samples), so the filter fuses gyro and wheel in sequence; then the waiting shares are
//      released oldest first, up to shares_this_period(), each checked for freshness, need and
//      surveyed background, then its signature, then handed to map fusion; the period's trust
//      work goes into the localizer's budget; then the scan (or, refused, the last pose again);
//      then the pose and diagnostic CAN frames.
// A period without a scan (period_timer.hpp): once a CAN input is stamped past the expected scan's
// stamp plus the tolerance (timer_due), or a scan's stamp shows the expected one was skipped, the
// driver closes the period with an empty scan stamped at the expected time: the held inputs stamped
// up to it and the IMU samples before it go to the localizer, then the waiting shares as at a scan
// (judged by the clock of the CAN input that closed it; a period a scan's stamp shows was skipped
// leaves them to the scan's own), the localizer predicts and the pose frames go out (flagged: no
// registration, Degraded).
// A scan stamped within half a period of a period the timer already closed is late: counted, not
// used, nothing published (the period had its pose); a scan after it opens the next period.
// Periods are numbered in the order closed, with or without a scan (the pose frames' counter).
// Deterministic and allocation-free; the localizer is reached only through LocalizerPort.
#pragma once

#include <cstdint>

#include "firmware/protocol/fnv1a.hpp"
#include "firmware/wire/diagnostic_frames.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/localizer_port.hpp"
#include "firmware/wire/pending_inputs.hpp"
#include "firmware/wire/period_timer.hpp"
#include "firmware/wire/pose_frames.hpp"

namespace v2xloc::firmware {

// FNV-1a over an IMU sample's bits (t, gyro, accel, saturated), chained from kImuDigestStart: two
// runs that handed the localizer the same samples in the same order have the same digest.
inline constexpr std::uint64_t kImuDigestStart = kFnv1aOffsetBasis;
std::uint64_t imu_digest_step(std::uint64_t digest, const ImuInput& sample);

// Map fusion's answers to the shares the driver handed it, and the periods without a scan.
struct PeriodCounters {
  std::uint64_t periods = 0;
  std::uint64_t map_handed = 0;          // verified shares handed to map fusion
  std::uint64_t map_fused = 0;           // of those: inserted or replaced a source's cloud
  std::uint64_t map_inconsistent = 0;    // refused: disagree with the infrastructure
  std::uint64_t map_infra_inconsistent = 0;  // of those, infrastructure shares (outvoted by the other units)
  std::uint64_t map_held_back = 0;       // agent shares with too little overlap to be checked
  std::uint64_t map_background_mismatch = 0;  // infrastructure shares off their unit's surveyed background
  std::uint64_t map_no_slot = 0;         // per-role source cap reached
  std::uint64_t map_stale = 0;           // not newer than the source's stored cloud
  std::uint64_t map_paced = 0;           // not fused: the source's stored cloud is recent (map.cloud_interval)
  std::uint64_t ego_frames_held = 0;     // ego scans refused for their time: last pose published again
  std::uint64_t periods_without_scan = 0;  // closed by the period timer: the localizer's prediction
  std::uint64_t late_scans = 0;          // ego scans for a period the timer had closed: not used
  std::uint64_t timer_restarts = 0;      // the inputs' clock stepped past max_periods_per_input periods
  std::uint64_t inputs_released_early = 0;  // CAN inputs handed before their period closed (held inputs full)
  std::uint64_t imu_handed = 0;          // IMU samples handed to the localizer
  std::uint64_t imu_digest = kImuDigestStart;  // imu_digest_step over those samples in order (runs compare it)
};

// What one period publishes. `output` refers to the localizer's (or the driver's held) output and
// stays valid until the next period.
struct PeriodOutput {
  const LocalizerFrameOutput* output = nullptr;
  std::uint32_t frame_index = 0;
  bool gnss_used = false;  // pose flag GnssUsed (false for a held pose)
  bool held = false;       // the scan was refused for its time: the last pose again
  bool without_scan = false;  // closed by the period timer: no scan, the filter's prediction
  PoseFrames pose{};
  DiagnosticFrames diagnostics{};
};

class PeriodDriver {
 public:
  // Installs `localizer` as the decoder's share filter: shares the map would not fuse are not hashed.
  PeriodDriver(InputDecoder& decoder, LocalizerPort& localizer);
  PeriodDriver(const PeriodDriver&) = delete;
  PeriodDriver& operator=(const PeriodDriver&) = delete;

  // Step 1: one received CAN frame at disciplined time time_ns, decoded and held for the period.
  DecodedCan on_can(const hal::CanFrame& frame, std::int64_t time_ns);
  // Step 2: one HID IMU input report read at disciplined time time_ns (queued, not yet applied).
  ImuReportKind on_imu_report(std::span<const std::uint8_t> report, std::int64_t time_ns) {
    return decoder_.decode_imu(report, time_ns);
  }
  // Step 3: the cloud InputDecoder::on_datagram() just completed, after the caller applied every
  // CAN frame received before it. local_time_ns: the disciplined clock read after those frames.
  DecodedCloud take_completed(std::int64_t local_time_ns);
  // The same with the decoder's own clock relation (emulation: epoch + receive time).
  DecodedCloud take_completed();
  // True for the clouds that close a period (an ego scan, used or refused).
  static bool closes_period(const DecodedCloud& cloud) {
    return cloud.kind == CloudKind::kEgoScan || cloud.kind == CloudKind::kEgoRejected;
  }
  // Step 4: `scan` (closes_period) closes the period; `publish(const PeriodOutput&)` gets each
  // period closed: first those the scan's stamp shows were skipped (without a scan), then the
  // scan's own (none for a late scan). Its points must still be valid: the caller may read further
  // V2X datagrams first (they do not touch the scan's buffer).
  template <class Publish>
  void close_period(const DecodedCloud& scan, Publish&& publish) {
    timer_.on_scan();
    double t = 0.0;
    if (scan.kind == CloudKind::kEgoScan) {
      while (timer_.next_skipped(scan.ego.t, t)) publish(close_without_scan(t, false));
      counters_.timer_restarts = timer_.restarts();
      if (timer_.late(scan.ego.t)) {
        ++counters_.late_scans;
        return;
      }
    }
    publish(close_with_scan(scan));
  }
  // The period timer is due: a CAN input stamped past the expected scan's stamp plus the
  // tolerance. The caller reads the IMU reports received by now, then calls close_overdue_periods.
  bool timer_due() const { return timer_.due(); }
  // Closes each period the timer names, without a scan, passing each to `publish`.
  template <class Publish>
  void close_overdue_periods(Publish&& publish) {
    double t = 0.0;
    while (timer_.next_due(t)) publish(close_without_scan(t, true));
    counters_.timer_restarts = timer_.restarts();
  }
  void configure_timer(const PeriodTimerParams& params) { timer_.configure(params); }
  const PeriodTimer& timer() const { return timer_; }

  const PeriodCounters& counters() const { return counters_; }
  // The latest published output (null before the first period).
  const LocalizerFrameOutput* latest() const { return has_output_ ? &latest_ : nullptr; }

 private:
  const PeriodOutput& close_with_scan(const DecodedCloud& scan);
  const PeriodOutput& close_without_scan(double t, bool release_shares_now);
  const PeriodOutput& publish_latest(bool gnss_used);
  void release_inputs();
  void release_inputs_until(double t);
  void release_imu_before(double t);
  void hold(const PendingInput& input);
  void release_shares();
  void count_insert(const MapInsertResult& result, bool is_agent);

  InputDecoder& decoder_;
  LocalizerPort& localizer_;
  PoseFrameEncoder pose_encoder_{};
  DiagnosticFrameEncoder diagnostic_encoder_{};
  LocalizerFrameOutput latest_{};
  bool has_output_ = false;
  PeriodOutput published_{};
  PeriodCounters counters_{};
  PendingInputs pending_{};
  PeriodTimer timer_{};
  std::int64_t input_time_ns_ = 0;     // the latest CAN input's disciplined time (a timer period's boundary)
  bool gnss_released_ = false;         // a GNSS fix went to the localizer in this period
  Pose3d body_T_lidar_ = Pose3d::Identity();  // the last scan's mount, for a period without one
};

}  // namespace v2xloc::firmware
