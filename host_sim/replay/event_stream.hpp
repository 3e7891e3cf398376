// The event order of a recording, shared by the offline evaluator (in-process) and the replayer
// (over emulated CAN + UDP), so both feed the localizer identically. It is the firmware's input
// order (firmware/wire/input_decoder.hpp) applied to a recording:
//   for each frame i at t_i: every CAN frame of the recording's candump log with t <= t_i not yet
//   emitted (log order); then every IMU HID report (recordings with one) received at or before t_i
//   not yet emitted (receive order; the period driver queues them and hands them on when the
//   period closes, so where they stand before the scan does not matter); then every map cloud
//   (infra / agent) with stamp <= t_i not yet emitted (stamp order); then ego scan i (none, or one
//   without points, in a lidar-blind spell: fault_injection.hpp).
// Events are wire bytes: CAN frames as hal::CanFrame, clouds as the UDP datagrams of the
// point-cloud fragmenter (quantized exactly as sent). WireEventDecoder hands them to the firmware's
// own InputDecoder and period driver, so the offline path sees the firmware's bits.
// Time: every event carries its recording time in ns (the emulated firmware's SimClock time);
// disciplined (wire) time = epoch_ns + recording time, epoch_ns = Unix time of recording t = 0.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "firmware/wire/diagnostic_frames.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/localizer_port.hpp"
#include "firmware/wire/period_driver.hpp"
#include "firmware/wire/pose_frames.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "hal/can_frame.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"
#include "host_sim/recording/recording_reader.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/replay/fault_injection.hpp"
#include "v2xloc/algo/localization/localizer.hpp"

namespace v2xloc::sim::replay {

struct WireEvent {
  enum class Kind : std::uint8_t { kCan, kMapCloud, kEgoScan, kImuReport };
  Kind kind = Kind::kCan;
  std::int64_t time_ns = 0;             // recording time [ns] (CAN log stamp, cloud stamp, frame stamp)
  hal::CanFrame can{};             // kCan
  hal::HidScriptLine imu{};        // kImuReport: the report bytes (time_ns = its receive time)
  std::vector<std::vector<std::uint8_t>> datagrams;  // clouds: the fragments, in send order
  std::uint32_t sender_id = 0;          // clouds
  std::uint32_t points_sent = 0;        // clouds: after the fragmenter's drops
  std::uint32_t points_dropped = 0;     // clouds: out of quantization range / not finite
  std::uint32_t times_clamped = 0;      // ego: point times beyond the u16 microsecond field
  int frame = -1;                       // kEgoScan: frame index
  cloud_io::PointCloud source;          // clouds: as recorded, before quantization (keep_source_clouds)
};

struct EventStreamConfig {
  float scale_m = firmware::kCloudScaleM;
  bool ego_point_times = true;          // send per-point times (deskew)
  std::size_t max_datagram_bytes = protocol::pointcloud_wire::kMaxDatagramBytes;
  int max_frames = -1;                  // < 0: all frames of the recording
  bool sign_map_shares = true;          // signature datagram before each share (sim test keys)
  bool keep_source_clouds = false;      // WireEvent::source set (the in-process evaluator's full precision)
  FaultSpec faults{};                   // fault injection (fault_injection.hpp); default none
  bool imu = true;                      // the recording's IMU reports, when it has them
};

struct EventStreamStats {
  std::size_t can_frames = 0, map_clouds = 0, ego_scans = 0, datagrams = 0, imu_reports = 0;
  std::uint64_t points_dropped = 0, times_clamped = 0;
  FaultStats faults{};
};

class EventStream {
 public:
  // Loads the CAN log (if any) and the map-cloud list. The reader must outlive the stream.
  bool open(const RecordingReader& reader, const EventStreamConfig& config, std::string& error);

  int frame_count() const { return frame_count_; }
  std::int64_t epoch_ns() const { return epoch_ns_; }
  std::int64_t frame_time_ns(int i) const;
  // Appends frame i's events in canonical order. Frames must be requested in order 0, 1, 2, ...
  bool next_frame(int i, std::vector<WireEvent>& out, std::string& error);
  const EventStreamStats& stats() const { return stats_; }
  // The IMU reports the stream delivers (IMU faults applied), all of them: the emulated firmware's
  // HID script (its device releases each once the clock reaches its receive time).
  const std::vector<hal::HidScriptLine>& imu_reports() const { return imu_; }
  // The trust list the firmware is provisioned with: the recording's trust_list.txt, or, for
  // recordings made before it existed, the same list derived from the map-cloud sensor names.
  const trust::TrustList& trust_list() const { return trust_list_; }

  // Sender id of a map-cloud sensor name ("infra_2" -> 3, "agent_1_lidar" -> 33); false if unknown.
  static bool sender_id_for(const MapCloudInfo& info, std::uint32_t& sender_id);

 private:
  // One recorded map cloud about to be sent: sender id, sequence number, stamp [ns of recording
  // time], signer (nullptr: unsigned) and the cloud as recorded.
  struct ShareSource {
    const MapCloudInfo* info = nullptr;
    std::uint32_t id = 0;
    std::uint32_t seq = 0;
    std::int64_t stamp_ns = 0;
    const SimSigner* signer = nullptr;
    cloud_io::PointCloud cloud;
  };
  // The rogue-source fault on one map cloud (FaultSpec rogue_*).
  struct RogueShare {
    bool active = false;                         // this cloud's source is the rogue
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // the pose the rogue declares
    cloud_io::PointCloud moved;                  // rogue_points: the points moved instead (else empty)
  };

  // The steps of next_frame(), in order.
  void append_can(std::int64_t t_i, std::vector<WireEvent>& out);
  void append_imu(std::int64_t t_i, std::vector<WireEvent>& out);
  void append_can_burst(const WireEvent& after, std::vector<WireEvent>& out);
  bool send_map_clouds(std::int64_t t_i, std::string& error);
  bool share_events(const MapCloudInfo& info, std::vector<WireEvent>& shares, std::string& error);
  const SimSigner* signer_for(const MapCloudInfo& info) const;
  RogueShare rogue_share(const MapCloudInfo& info, const cloud_io::PointCloud& cloud) const;
  bool append_rogue_copies(const ShareSource& source, const RogueShare& rogue, const cloud_io::PointCloud& rogue_cloud,
                           std::vector<WireEvent>& shares, std::string& error);
  void deliver_due_shares(std::int64_t t_i, std::vector<WireEvent>& out);
  bool append_ego_scan(int i, std::int64_t t_i, std::vector<WireEvent>& out, std::string& error);

  bool map_share(std::uint32_t sender_id, std::uint32_t seq, std::int64_t stamp_ns, const Eigen::Isometry3d& pose,
                 const cloud_io::PointCloud& cloud, const SimSigner* signer, WireEvent& ev, std::string& error) const;
  bool fragment(protocol::CloudMessageType type, std::uint32_t sender_id, std::uint32_t seq,
                std::int64_t stamp_ns, const Eigen::Isometry3d& pose, const cloud_io::PointCloud& cloud,
                bool with_times, WireEvent& ev, std::string& error) const;

  const RecordingReader* reader_ = nullptr;
  EventStreamConfig config_{};
  int frame_count_ = 0;
  std::int64_t epoch_ns_ = 0;
  struct TimedCan {
    std::int64_t time_ns;
    hal::CanFrame frame;
  };
  std::vector<TimedCan> can_;
  std::size_t next_can_ = 0, next_cloud_ = 0, next_imu_ = 0;
  std::vector<hal::HidScriptLine> imu_;
  int next_frame_ = 0;
  std::vector<std::uint32_t> cloud_seq_;  // per sender id
  EventStreamStats stats_{};
  trust::TrustList trust_list_{};
  std::vector<SimSigner> signers_;
  bool sign_shares_ = false;  // map shares get a signature datagram (digest over their fragments)
  FaultInjector faults_{};
  std::vector<WireEvent> delayed_;        // V2X shares held back by the delay fault
  bool burst_done_ = false;
};

// Wire events -> the firmware's period driver (firmware/wire/period_driver.hpp): the same decode,
// order, share checks and localizer calls as the firmware, and the ego frames' outputs encoded as
// its pose and diagnostic CAN frames. Transport only: an event's time is its receive time.
struct DecodedFrame {
  int frame = -1;             // the period's index (periods closed before it)
  bool without_scan = false;  // closed by the period timer (firmware/wire/period_timer.hpp)
  LocalizerFrameOutput output{};
  firmware::PoseFrames pose{};
  firmware::DiagnosticFrames diagnostics{};
};

// Sees every localizer input WireEventDecoder applies, in order, just before it is applied (the
// target fixture's writer records them: tools/target).
class LocalizerInputTap {
 public:
  virtual void vehicle(const VehicleInput& input) = 0;
  virtual void gnss(const GnssInput& input) = 0;
  virtual void imu(const ImuInput& input) = 0;
  virtual void map_cloud(const MapCloudInput& input) = 0;
  virtual void period_work(double instructions) = 0;
  virtual void ego_scan(const EgoScanInput& input) = 0;

 protected:
  ~LocalizerInputTap() = default;
};

class WireEventDecoder {
 public:
  // `localizer` is any LocalizerPort (firmware::LocalizerAdapter<Localizer> for the plain one).
  WireEventDecoder(firmware::InputDecoder& decoder, firmware::LocalizerPort& localizer)
      : decoder_(decoder), port_(localizer), driver_(decoder, port_) {}
  WireEventDecoder(const WireEventDecoder&) = delete;
  WireEventDecoder& operator=(const WireEventDecoder&) = delete;
  // Hands each period the event closed to `on_frame` (an ego scan, used or refused, and the periods
  // its stamp shows were skipped; a CAN frame past the period timer's deadline: the periods closed
  // without a scan); returns how many.
  int feed(const WireEvent& event, const std::function<void(const DecodedFrame&)>& on_frame);
  const firmware::PeriodDriver& driver() const { return driver_; }
  void set_tap(LocalizerInputTap* tap) { port_.tap = tap; }

 private:
  // The caller's port, with the tap (when set) seeing each input just before it is applied.
  struct TappedPort final : firmware::LocalizerPort {
    explicit TappedPort(firmware::LocalizerPort& p) : inner(p) {}
    bool wants(std::uint32_t source_id, double t) const override { return inner.wants(source_id, t); }
    bool fits_background(std::uint32_t source_id, const Mat4d& world_T_sensor,
                         std::span<const Vec3f> points) const override {
      return inner.fits_background(source_id, world_T_sensor, points);
    }
    bool awaiting_first_map() const override { return inner.awaiting_first_map(); }
    std::uint32_t map_clouds_per_period() const override { return inner.map_clouds_per_period(); }
    void add_period_work(double instructions) override {
      if (tap != nullptr) tap->period_work(instructions);
      inner.add_period_work(instructions);
    }
    void on_vehicle(const VehicleInput& input) override {
      if (tap != nullptr) tap->vehicle(input);
      inner.on_vehicle(input);
    }
    void on_gnss(const GnssInput& input) override {
      if (tap != nullptr) tap->gnss(input);
      inner.on_gnss(input);
    }
    void on_imu(const ImuInput& input) override {
      if (tap != nullptr) tap->imu(input);
      inner.on_imu(input);
    }
    MapInsertResult on_map_cloud(const MapCloudInput& input) override {
      if (tap != nullptr) tap->map_cloud(input);
      return inner.on_map_cloud(input);
    }
    const LocalizerFrameOutput& on_ego_scan(const EgoScanInput& input) override {
      if (tap != nullptr) tap->ego_scan(input);
      return inner.on_ego_scan(input);
    }
    firmware::LocalizerPort& inner;
    LocalizerInputTap* tap = nullptr;
  };

  firmware::InputDecoder& decoder_;
  TappedPort port_;
  firmware::PeriodDriver driver_;
};

// The offline evaluator's loop: the whole event stream in-process. `decoder` is large (make it
// with std::make_unique); its epoch is set from the recording. False + error on I/O failures.
// tap (optional) sees every input applied.
bool run_offline(const RecordingReader& reader, Localizer& localizer, firmware::InputDecoder& decoder,
                 const EventStreamConfig& config, const std::function<void(const DecodedFrame&)>& on_frame,
                 std::string& error, LocalizerInputTap* tap = nullptr);

}  // namespace v2xloc::sim::replay
