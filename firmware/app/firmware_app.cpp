#include "firmware/app/firmware_app.hpp"

#include <algorithm>

#include <cmath>

#include "hal/hid_imu_report.hpp"

namespace v2xloc::firmware {
namespace {

// GPS time (week, time of week) of the whole second -> Unix ns. GPS epoch 1980-01-06 = Unix
// 315964800 s; GPS is ahead of UTC by the leap seconds (18 s since 2017-01-01).
constexpr std::int64_t kGpsEpochUnixS = 315964800;
constexpr std::int64_t kGpsLeapSeconds = 18;

std::int64_t gps_second_to_unix_ns(std::uint16_t week, double time_of_week_s) {
  const std::int64_t tow_ms = std::llround(time_of_week_s * 1000.0);  // 1 ms on the wire
  const std::int64_t gps_s = static_cast<std::int64_t>(week) * 604800 + tow_ms / 1000;
  return (gps_s + kGpsEpochUnixS - kGpsLeapSeconds) * 1'000'000'000;
}

std::uint8_t saturate_u8(std::uint64_t v) { return v > 255 ? 255 : static_cast<std::uint8_t>(v); }

}  // namespace

FirmwareApp::FirmwareApp(const FirmwareHal& hal, InputDecoder& decoder, LocalizerPort& localizer,
                         const FirmwareConfig& config)
    : hal_(hal), decoder_(decoder), driver_(decoder, localizer), config_(config) {
  driver_.configure_timer(config.period_timer);
}

hal::Status FirmwareApp::start() {
  start_ns_ = hal_.clock.monotonic_ns();
  next_heartbeat_ns_ = start_ns_ + config_.heartbeat_period_ns;
  last_can_ns_ = last_datagram_ns_ = last_gnss_ns_ = last_ego_scan_ns_ = start_ns_;
  if (hal_.led != nullptr) hal_.led->set_value(false);
  if (hal_.imu != nullptr) {
    std::array<std::uint8_t, hal::hid_imu::kOutputReportBytes> command{};
    hal::hid_imu::encode_command(hal::hid_imu::Command::kSetRate, config_.imu_rate_hz, command);
    if (hal_.imu->write_report(command) != hal::Status::kOk) ++counters_.imu_command_failed;
    ImuDecoderConfig imu;
    imu.rate_hz = config_.imu_rate_hz;
    decoder_.imu().configure(imu);
  }
  return hal_.can.accept_all();
}

std::size_t FirmwareApp::poll_once() {
  ++counters_.polls;
  std::size_t handled = drain_can();
  handled += poll_pps();
  handled += drain_imu();
  handled += drain_datagrams();
  decoder_.expire(hal_.clock.monotonic_ns());
  maybe_heartbeat();
  return handled;
}

std::size_t FirmwareApp::drain_can() {
  std::size_t n = 0;
  hal::CanRxFrame rx;
  while (n < config_.max_can_frames_per_drain && hal_.can.receive(rx) == hal::Status::kOk) {
    ++n;
    ++counters_.can_rx;
    last_can_ns_ = rx.timestamp_ns;
    if (rx.error || rx.remote) {
      ++counters_.can_error_frames;
      continue;
    }
    const DecodedCan decoded = driver_.on_can(rx.frame, disciplined(rx.timestamp_ns));
    if (decoded.kind == CanInputKind::kGnssFix) {
      last_gnss_ns_ = rx.timestamp_ns;
      discipline_clock(rx.timestamp_ns);
    }
    if (driver_.timer_due()) close_overdue_periods();
  }
  return n;
}

// The period timer fired on this CAN frame's stamp: the shares already received on the V2X
// endpoint and the IMU reports received by now belong to the period (as at a scan: the input order
// is a function of what was sent, not of the read timing), then each overdue period goes out.
// Reading the V2X endpoint drains CAN frames again; those do not close periods from in here.
void FirmwareApp::close_overdue_periods() {
  if (closing_overdue_) return;
  closing_overdue_ = true;
  drain_link(hal_.clouds, false);
  drain_imu();
  driver_.close_overdue_periods([this](const PeriodOutput& period) { publish(period); });
  closing_overdue_ = false;
}

void FirmwareApp::discipline_clock(std::int64_t rx_monotonic_ns) {
  // The PPS edge marks the start of the GNSS second named by the next time message of that second.
  if (!pps_pending_) return;
  const std::int64_t age = rx_monotonic_ns - pps_edge_ns_;
  if (age < 0) return;  // the message predates the edge: wait for the next one
  pps_pending_ = false;
  if (age >= 1'000'000'000) return;  // no time message within the second: edge unusable
  const protocol::GnssTime& t = decoder_.can().last_gnss_time();
  const std::int64_t gnss_ns = gps_second_to_unix_ns(t.week, t.time_of_week_s);
  const std::int64_t step = gnss_ns - disciplined(pps_edge_ns_);
  if (counters_.clock_disciplined > 0 && (step > config_.max_clock_step_ns || step < -config_.max_clock_step_ns)) {
    ++counters_.gnss_time_rejected;
    return;
  }
  if (hal_.clock.set_time(gnss_ns, pps_edge_ns_) == hal::Status::kOk) {
    ++counters_.clock_disciplined;
  }
}

std::size_t FirmwareApp::poll_pps() {
  if (hal_.pps == nullptr) return 0;
  std::size_t n = 0;
  hal::GpioEdge edge;
  while (hal_.pps->read_edge(edge) == hal::Status::kOk) {
    ++n;
    if (edge.kind != hal::GpioEdge::Kind::kRising) continue;
    ++counters_.pps_edges;
    pps_pending_ = true;
    pps_edge_ns_ = edge.timestamp_ns;
  }
  return n;
}

// Every queued HID report into the IMU decoder, stamped on the disciplined clock; the samples reach
// the localizer when the period closes (PeriodDriver), so when they are read does not matter.
std::size_t FirmwareApp::drain_imu() {
  if (hal_.imu == nullptr) return 0;
  std::size_t n = 0;
  hal::HidReportInfo info;
  while (n < config_.max_imu_reports_per_drain) {
    const hal::Status s = hal_.imu->read_report(imu_buffer_, info);
    if (s == hal::Status::kWouldBlock) break;
    ++n;
    if (s != hal::Status::kOk) {
      ++counters_.imu_reads_failed;
      if (s != hal::Status::kBufferTooSmall) break;  // a device error: try again next poll
      continue;
    }
    driver_.on_imu_report(std::span<const std::uint8_t>(imu_buffer_.data(), info.size), disciplined(info.timestamp_ns));
  }
  return n;
}

std::size_t FirmwareApp::drain_datagrams() {
  // V2X first: the shares received before an ego scan reach its period boundary (the input order
  // the offline paths use: map clouds up to t, then the scan at t).
  const std::size_t n = drain_link(hal_.clouds, false);
  return n + drain_link(hal_.ego, true);
}

std::size_t FirmwareApp::drain_link(hal::DatagramLink& link, bool ego_link) {
  std::size_t n = 0;
  hal::DatagramInfo info;
  while (n < config_.max_datagrams_per_poll) {
    const hal::Status s = link.receive(datagram_buffer_, info);
    if (s == hal::Status::kBufferTooSmall) {
      ++counters_.datagrams_oversize;
      ++n;
      continue;
    }
    if (s != hal::Status::kOk) break;
    ++n;
    ++counters_.datagrams_rx;
    const std::int64_t now = hal_.clock.monotonic_ns();
    last_datagram_ns_ = now;
    const std::span<const std::uint8_t> bytes(datagram_buffer_.data(), info.size);
    const DatagramChannel channel = ego_link ? DatagramChannel::kEgo : DatagramChannel::kV2x;
    if (!decoder_.on_datagram(bytes, now, disciplined(now), channel)) continue;
    // Input order: every CAN frame sent before this cloud's last fragment goes first; the clock
    // is read again after them (the emulated clock moves with the CAN link).
    drain_can();
    const DecodedCloud decoded = driver_.take_completed(disciplined(hal_.clock.monotonic_ns()));
    if (!PeriodDriver::closes_period(decoded)) continue;
    // Shares already received on the V2X endpoint belong to this period whichever socket was read
    // first (two sockets have no common order): the input order is then a function of the
    // datagrams, not of the read timing.
    if (ego_link) drain_link(hal_.clouds, false);
    drain_imu();  // every report received by the period boundary
    if (decoded.kind == CloudKind::kEgoScan && !decoded.ego.points.empty()) last_ego_scan_ns_ = now;
    driver_.close_period(decoded, [this](const PeriodOutput& period) { publish(period); });
  }
  return n;
}

void FirmwareApp::send(const hal::CanFrame& frame) {
  if (hal_.can.send(frame) == hal::Status::kOk) {
    ++counters_.can_tx;
  } else {
    ++counters_.can_tx_failed;
  }
}

void FirmwareApp::publish(const PeriodOutput& period) {
  send(period.pose.position);
  send(period.pose.attitude);
  send(period.pose.sigma);
  // Diagnostics (registration, gate decision, odometry) after the pose; odometry attitude last:
  // the replayer's lockstep waits for it.
  send(period.diagnostics.registration_position);
  send(period.diagnostics.registration_quality);
  send(period.diagnostics.gate);
  send(period.diagnostics.odometry_position);
  send(period.diagnostics.odometry_attitude);
  ++counters_.frames_published;
  const bool localized = period.output->localized;
  if (hal_.led != nullptr && localized != led_on_) {
    led_on_ = localized;
    hal_.led->set_value(led_on_);
    ++counters_.led_changes;
  }
}

protocol::Heartbeat FirmwareApp::heartbeat_now() const {
  const std::int64_t now = hal_.clock.monotonic_ns();
  const CanCounters& c = decoder_.can().counters();
  const CloudCounters& d = decoder_.clouds().counters();
  const ShareCounters& s = decoder_.shares().counters();
  const PeriodCounters& p = driver_.counters();
  const protocol::ReassemblyCounters& r = decoder_.clouds().reassembly_counters();
  protocol::Heartbeat hb;
  hb.state = localizer_state(driver_.latest());
  namespace err = protocol::heartbeat_error;
  hb.error_flags = static_cast<std::uint8_t>(
      (now - last_can_ns_ > config_.input_timeout_ns ? err::kCanTimeout : 0u) |
      (now - last_datagram_ns_ > config_.input_timeout_ns ? err::kUdpTimeout : 0u) |
      (now - last_gnss_ns_ > config_.gnss_timeout_ns ? err::kGnssTimeout : 0u) |
      (r.over_capacity + r.frames_evicted > 0 ? err::kCapacityOverflow : 0u));
  // A LiDAR that sends nothing, or scans without points, while the V2X shares keep the UDP alive.
  hb.lidar_timeout = now - last_ego_scan_ns_ > config_.ego_scan_timeout_ns;
  hb.uptime_s = static_cast<double>(now - start_ns_) * 1e-9;
  hb.can_rx_errors = saturate_u8(c.can_rejected + counters_.can_error_frames);
  hb.udp_dropped = saturate_u8(d.datagrams_rejected + counters_.datagrams_oversize + r.frames_timed_out +
                               r.frames_evicted + d.clouds_rejected + s.shares_malformed + s.shares_untrusted +
                               s.shares_queue_dropped + d.wrong_channel + d.ego_time_rejected + p.map_inconsistent +
                               p.map_held_back + p.map_background_mismatch + p.map_no_slot);
  hb.counter = heartbeat_counter_;
  return hb;
}

protocol::TrustRejections FirmwareApp::trust_rejections_now() const {
  const trust::VerifierCounters& v = decoder_.shares().verifier().counters();
  protocol::TrustRejections t;
  t.unknown_signer = saturate_u8(v.unknown_signer);
  t.bad_signature = saturate_u8(v.bad_signature);
  t.too_old = saturate_u8(v.too_old);
  t.future = saturate_u8(v.future);
  t.replay = saturate_u8(v.replay);
  t.queue_overflow = saturate_u8(decoder_.shares().counters().shares_queue_dropped);
  t.pose_mismatch = static_cast<std::uint8_t>(v.pose_mismatch > 15 ? 15 : v.pose_mismatch);  // a 4-bit signal
  return t;
}

protocol::InputGuards FirmwareApp::input_guards_now() const {
  const auto saturate = [](std::uint64_t v) {
    return static_cast<std::uint16_t>(v > protocol::kInputGuardsMax ? protocol::kInputGuardsMax : v);
  };
  const CanCounters& c = decoder_.can().counters();
  protocol::InputGuards g;
  g.can_crc_rejected = saturate(c.can_rejected);  // DLC / CRC / range; counter repeats separately
  g.can_counter_rejected = saturate(c.can_repeated);
  g.ego_time_rejected = saturate(decoder_.clouds().counters().ego_time_rejected);
  g.missing_signature = saturate(decoder_.shares().verifier().counters().missing_signature);
  const std::uint64_t off_background =
      driver_.counters().map_background_mismatch + decoder_.shares().counters().shares_off_background;
  g.background_mismatch = static_cast<std::uint8_t>(off_background > 15 ? 15 : off_background);  // a 4-bit signal
  return g;
}

void FirmwareApp::maybe_heartbeat() {
  const std::int64_t now = hal_.clock.monotonic_ns();
  if (now < next_heartbeat_ns_) return;
  send(protocol::pack(heartbeat_now()));
  protocol::TrustRejections trust = trust_rejections_now();
  trust.counter = heartbeat_counter_;
  send(protocol::pack(trust));
  protocol::InputGuards guards = input_guards_now();
  guards.counter = heartbeat_counter_;
  send(protocol::pack(guards));
  heartbeat_counter_ = static_cast<std::uint8_t>((heartbeat_counter_ + 1) % protocol::kCounterModulo);
  ++counters_.heartbeats;
  // Simulated time may jump several periods: one heartbeat, then the next period boundary.
  next_heartbeat_ns_ += config_.heartbeat_period_ns * ((now - next_heartbeat_ns_) / config_.heartbeat_period_ns + 1);
}

}  // namespace v2xloc::firmware
