// The ECU application loop: polls the HAL, decodes (InputDecoder), hands the decoded inputs to the
// localizer (the only caller of the localizer in the firmware), publishes the fused pose and the
// diagnostic frames on CAN after every ego scan, drives the "localized" LED, disciplines the clock
// on GNSS PPS edges and sends a 1 Hz heartbeat. It only knows hal/ interfaces; main() picks backends.
// Input order: before a completed cloud is handed to the localizer, every pending CAN frame is
// decoded and applied first (the order firmware/wire/input_decoder.hpp defines).
// No allocation: all buffers are members of static objects.
#pragma once

#include <array>
#include <cstdint>

#include "firmware/app/localizer_port.hpp"
#include "firmware/wire/diagnostic_frames.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/pose_frames.hpp"
#include "hal/can_bus.hpp"
#include "hal/clock.hpp"
#include "hal/datagram_link.hpp"
#include "hal/gpio_line.hpp"

namespace v2xloc::firmware {

struct FirmwareHal {
  hal::CanBus& can;              // vehicle bus: GNSS + vehicle motion in, pose + heartbeat out
  hal::DatagramLink& clouds;     // UDP: V2X map shares (and their signatures)
  hal::Clock& clock;
  hal::GpioLine* pps = nullptr;  // GNSS PPS input (optional)
  hal::GpioLine* led = nullptr;  // "localized" LED output (optional)
  hal::DatagramLink* ego = nullptr;  // UDP: ego sensor scans on their own endpoint (null: legacy,
                                     // one socket, classified by message type: spoofable)
};

struct FirmwareConfig {
  std::int64_t heartbeat_period_ns = 1'000'000'000;
  std::int64_t input_timeout_ns = 1'000'000'000;   // heartbeat error bits: CAN / UDP silent
  std::int64_t gnss_timeout_ns = 2'000'000'000;
  // Once disciplined, a GNSS second may move the clock by at most this (a receiver's time does
  // not jump; a week number going 2300 -> 0 -> 65535 is a fault or a spoof, not a correction).
  std::int64_t max_clock_step_ns = 1'000'000'000;
  std::size_t max_datagrams_per_poll = 4096;       // bounded work per poll
  std::size_t max_can_frames_per_drain = 65536;
};

struct FirmwareCounters {
  std::uint64_t polls = 0;
  std::uint64_t can_rx = 0;
  std::uint64_t can_error_frames = 0;
  std::uint64_t can_tx = 0;
  std::uint64_t can_tx_failed = 0;
  std::uint64_t datagrams_rx = 0;
  std::uint64_t datagrams_oversize = 0;   // did not fit the receive buffer (discarded by the link)
  std::uint64_t frames_published = 0;
  std::uint64_t heartbeats = 0;
  std::uint64_t pps_edges = 0;
  std::uint64_t clock_disciplined = 0;
  std::uint64_t gnss_time_rejected = 0;  // GNSS time implausible against the running clock: not applied
  std::uint64_t map_inconsistent = 0;    // verified shares map fusion refused: disagree with the infrastructure
  std::uint64_t map_infra_inconsistent = 0;  // of those, infrastructure shares (outvoted by the other units)
  std::uint64_t map_held_back = 0;       // agent shares with too little overlap to be checked
  std::uint64_t map_background_mismatch = 0;  // infrastructure shares off their unit's surveyed background
  std::uint64_t map_no_slot = 0;         // per-role source cap reached
  std::uint64_t map_stale = 0;           // not newer than the source's stored cloud
  std::uint64_t map_paced = 0;           // not fused: the source's stored cloud is recent (map_cloud_interval)
  std::uint64_t ego_frames_held = 0;     // ego scans refused for their time: last pose published again
  std::uint64_t led_changes = 0;
};

class FirmwareApp {
 public:
  FirmwareApp(const FirmwareHal& hal, InputDecoder& decoder, LocalizerPort& localizer,
              const FirmwareConfig& config = {});

  // Accept-all CAN filter, LED off, heartbeat schedule. Call once before the loop.
  hal::Status start();
  // One pass over every input; returns how many events were handled (0 = idle).
  std::size_t poll_once();

  const FirmwareCounters& counters() const { return counters_; }
  const InputDecoder& decoder() const { return decoder_; }
  protocol::Heartbeat heartbeat_now() const;
  // The security diagnostics frames' contents (0x301, 0x302), sent with every heartbeat.
  protocol::TrustRejections trust_rejections_now() const;
  protocol::InputGuards input_guards_now() const;

 private:
  std::size_t drain_can();
  void apply_can(const DecodedCan& decoded, std::int64_t rx_monotonic_ns);
  void apply_cloud(const DecodedCloud& decoded);
  std::size_t drain_datagrams();
  std::size_t drain_link(hal::DatagramLink& link, bool ego_link);
  void close_period(bool ego_link);
  std::size_t poll_pps();
  void maybe_heartbeat();
  void publish_pose(const LocalizerFrameOutput& out, std::uint32_t frame_index, bool gnss_used);
  void discipline_clock(std::int64_t rx_monotonic_ns);
  void send(const hal::CanFrame& frame);
  std::int64_t disciplined(std::int64_t monotonic_ns) const {
    return monotonic_ns + (hal_.clock.time_ns() - hal_.clock.monotonic_ns());
  }

  FirmwareHal hal_;
  InputDecoder& decoder_;
  LocalizerPort& localizer_;
  FirmwareConfig config_;
  FirmwareCounters counters_{};
  PoseFrameEncoder pose_encoder_{};
  DiagnosticFrameEncoder diagnostic_encoder_{};
  LocalizerFrameOutput latest_{};
  bool has_output_ = false;
  bool led_on_ = false;
  std::uint8_t heartbeat_counter_ = 0;
  std::int64_t start_ns_ = 0;
  std::int64_t next_heartbeat_ns_ = 0;
  std::int64_t last_can_ns_ = 0, last_datagram_ns_ = 0, last_gnss_ns_ = 0;
  bool pps_pending_ = false;
  std::int64_t pps_edge_ns_ = 0;
  std::array<std::uint8_t, 2048> datagram_buffer_{};  // > 1400-byte fragments; larger ones are counted
};

}  // namespace v2xloc::firmware
