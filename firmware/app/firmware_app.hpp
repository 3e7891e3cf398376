// The ECU application loop: polls the HAL, hands CAN frames and completed clouds to the period
// driver (firmware/wire/period_driver.hpp: the order of a period, the share checks, the localizer
// calls), sends the pose and diagnostic frames it publishes every period (with or without an ego
// scan: the period timer), drives the
// "localized" LED, disciplines the clock on GNSS PPS edges and sends a 1 Hz heartbeat. It only
// knows hal/ interfaces; main() picks backends. What is left here is transport: which socket is
// read when, and which clock stamps an input.
// No allocation: all buffers are members of static objects.
#pragma once

#include <array>
#include <cstdint>

#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/localizer_port.hpp"
#include "firmware/wire/period_driver.hpp"
#include "hal/can_bus.hpp"
#include "hal/clock.hpp"
#include "hal/datagram_link.hpp"
#include "hal/gpio_line.hpp"
#include "hal/hid_device.hpp"

namespace v2xloc::firmware {

struct FirmwareHal {
  hal::CanBus& can;              // vehicle bus: GNSS + vehicle motion in, pose + heartbeat out
  hal::DatagramLink& clouds;     // UDP: V2X map shares (and their signatures)
  hal::DatagramLink& ego;        // UDP: ego sensor scans, on their own endpoint
  hal::Clock& clock;
  hal::GpioLine* pps = nullptr;  // GNSS PPS input (optional)
  hal::GpioLine* led = nullptr;  // "localized" LED output (optional)
  hal::HidDevice* imu = nullptr;  // USB HID IMU (optional; hal/HID_IMU_REPORT.md)
};

struct FirmwareConfig {
  std::int64_t heartbeat_period_ns = 1'000'000'000;
  std::int64_t input_timeout_ns = 1'000'000'000;   // heartbeat error bits: CAN / UDP silent
  std::int64_t gnss_timeout_ns = 2'000'000'000;
  // Heartbeat LidarTimeout: no ego scan with points for longer than this (5 LiDAR periods).
  std::int64_t ego_scan_timeout_ns = 500'000'000;
  PeriodTimerParams period_timer{};                // periods closed without a scan (period_timer.hpp)
  // Once disciplined, a GNSS second may move the clock by at most this (a receiver's time does
  // not jump; a week number going 2300 -> 0 -> 65535 is a fault or a spoof, not a correction).
  std::int64_t max_clock_step_ns = 1'000'000'000;
  std::size_t max_datagrams_per_poll = 4096;       // bounded work per poll
  std::size_t max_can_frames_per_drain = 65536;
  std::size_t max_imu_reports_per_drain = 1024;    // > the hidraw queue (64 reports)
  std::uint16_t imu_rate_hz = 200;                 // commanded at start (HID output report 2)
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
  std::uint64_t led_changes = 0;
  std::uint64_t imu_reads_failed = 0;    // HID read errors other than "nothing queued"
  std::uint64_t imu_command_failed = 0;  // the set-rate command at start was not accepted
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
  // Map fusion's answers and held frames (the period driver's counts).
  const PeriodCounters& period_counters() const { return driver_.counters(); }
  const InputDecoder& decoder() const { return decoder_; }
  protocol::Heartbeat heartbeat_now() const;
  // The security diagnostics frames' contents (0x301, 0x302), sent with every heartbeat.
  protocol::TrustRejections trust_rejections_now() const;
  protocol::InputGuards input_guards_now() const;

 private:
  std::size_t drain_can();
  std::size_t drain_datagrams();
  std::size_t drain_link(hal::DatagramLink& link, bool ego_link);
  std::size_t poll_pps();
  std::size_t drain_imu();
  void maybe_heartbeat();
  void publish(const PeriodOutput& period);
  void close_overdue_periods();
  void discipline_clock(std::int64_t rx_monotonic_ns);
  void send(const hal::CanFrame& frame);
  std::int64_t disciplined(std::int64_t monotonic_ns) const {
    return monotonic_ns + (hal_.clock.time_ns() - hal_.clock.monotonic_ns());
  }

  FirmwareHal hal_;
  InputDecoder& decoder_;
  PeriodDriver driver_;
  FirmwareConfig config_;
  FirmwareCounters counters_{};
  bool led_on_ = false;
  bool closing_overdue_ = false;  // close_overdue_periods is running (it reads the V2X endpoint)
  std::uint8_t heartbeat_counter_ = 0;
  std::int64_t start_ns_ = 0;
  std::int64_t next_heartbeat_ns_ = 0;
  std::int64_t last_can_ns_ = 0, last_datagram_ns_ = 0, last_gnss_ns_ = 0, last_ego_scan_ns_ = 0;
  bool pps_pending_ = false;
  std::int64_t pps_edge_ns_ = 0;
  std::array<std::uint8_t, 2048> datagram_buffer_{};  // > 1400-byte fragments; larger ones are counted
  std::array<std::uint8_t, 64> imu_buffer_{};         // a full-speed HID report; a longer one is malformed
};

}  // namespace v2xloc::firmware
