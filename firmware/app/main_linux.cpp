// v2xloc-firmware: the ECU application on Linux. Chooses the HAL backends (real: SocketCAN, UDP,
// libgpiod, hidapi; --emulated: CAN over UDP on loopback, SimClock driven by the replayer,
// scripted PPS), builds the static objects, prints their memory, and runs the poll loop.
// Options (also as key=value lines in --config FILE; CLI11): --help and firmware/README.md. main()
// reads as its steps: options, origin, static objects, backends, loop, exit report.
#include <poll.h>
#include <sys/socket.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "firmware/app/alloc_counter.hpp"
#include "firmware/wire/background_store.hpp"
#include "firmware/app/emulated_wiring.hpp"
#include "firmware/app/firmware_app.hpp"
#include "firmware/app/configure_localizer.hpp"
#include "firmware/trust/trust_list.hpp"
#include "hal/emulated/emulated_can_bus.hpp"
#include "hal/emulated/scripted_hid_device.hpp"
#include "hal/emulated/sim_clock.hpp"
#include "hal/linux/gpiod_line.hpp"
#include "hal/linux/hidapi_device.hpp"
#include "hal/linux/linux_clock.hpp"
#include "hal/linux/socketcan_bus.hpp"
#include "hal/linux/udp_link.hpp"

extern "C" {
extern char __bss_start;  // GNU ld: start of .bss
extern char _end;         // end of .bss
extern char __data_start;
extern char _edata;
}

namespace {

using namespace v2xloc;
using namespace v2xloc::firmware;

// ---- The static objects of the ECU (BSS; nothing of this size lives on the stack or heap). ----
Localizer g_localizer;
InputDecoder g_decoder;
BackgroundStore g_backgrounds;  // surveyed backgrounds the localizer reads (trust list `background` lines)

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

void print_memory() {
  std::printf("v2xloc-firmware: localizer: v2xloc::Localizer\n");
  std::printf("v2xloc-firmware: static memory: localizer %.1f MiB, decoder (reassembler %zu slots x %zu points + cloud buffers) %.1f MiB,"
              " backgrounds (%zu units x %zu cells) %.1f KiB, app %zu B; .bss %.1f MiB, .data %zu B\n",
              sizeof(Localizer) / 1048576.0, kReassemblySlots, kMaxCloudPoints, sizeof(InputDecoder) / 1048576.0,
              BackgroundStore::kUnits, BackgroundStore::kCells, sizeof(BackgroundStore) / 1024.0,
              sizeof(FirmwareApp), static_cast<double>(&_end - &__bss_start) / 1048576.0,
              static_cast<std::size_t>(&_edata - &__data_start));
}

void force_receive_buffer(int fd, int bytes) {
  // SO_RCVBUFFORCE (root / CAP_NET_ADMIN) lifts the rmem_max cap so a 100k-point scan
  // (~800 fragments) fits the socket queue; otherwise SO_RCVBUF up to rmem_max.
  if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) != 0) {
    setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
  }
  int actual = 0;
  socklen_t len = sizeof actual;
  getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &actual, &len);
  std::printf("v2xloc-firmware: cloud socket receive buffer %d bytes\n", actual);
}

// Every IMU report read lands in one count: samples + malformed + self_test_failed + repeated +
// out_of_order + time_rejected = reports.
void print_imu_counters(const FirmwareApp& app) {
  const ImuCounters& i = app.decoder().imu().counters();
  const FirmwareCounters& c = app.counters();
  const LocalizerCounters& l = g_localizer.counters();
  std::printf("v2xloc-firmware: imu to the localizer %llu (digest %016llx), received %u invalid %u\n",
              (unsigned long long)app.period_counters().imu_handed, (unsigned long long)app.period_counters().imu_digest,
              l.imu_received, l.imu_invalid);
  std::printf("v2xloc-firmware: imu reports %llu decoded %llu handed %llu lost %llu repeated %llu out_of_order %llu"
              " saturated %llu rejected %llu (malformed %llu self_test_failed %llu time_rejected %llu) unsynced %llu"
              " queue_dropped %llu read_errors %llu command_failed %llu\n",
              (unsigned long long)i.reports, (unsigned long long)i.samples, (unsigned long long)i.handed,
              (unsigned long long)i.lost, (unsigned long long)i.repeated, (unsigned long long)i.out_of_order,
              (unsigned long long)i.saturated, (unsigned long long)i.rejected(), (unsigned long long)i.malformed,
              (unsigned long long)i.self_test_failed, (unsigned long long)i.time_rejected, (unsigned long long)i.unsynced,
              (unsigned long long)i.queue_dropped, (unsigned long long)c.imu_reads_failed,
              (unsigned long long)c.imu_command_failed);
}

void print_counters(const FirmwareApp& app) {
  const FirmwareCounters& c = app.counters();
  const CanCounters& can = app.decoder().can().counters();
  const CloudCounters& d = app.decoder().clouds().counters();
  const ShareCounters& s = app.decoder().shares().counters();
  const protocol::ReassemblyCounters& r = app.decoder().clouds().reassembly_counters();
  std::printf("v2xloc-firmware: polls %llu can_rx %llu can_err %llu can_tx %llu tx_fail %llu datagrams %llu oversize %llu"
              " frames %llu heartbeats %llu pps %llu disciplined %llu\n",
              (unsigned long long)c.polls, (unsigned long long)c.can_rx, (unsigned long long)c.can_error_frames,
              (unsigned long long)c.can_tx, (unsigned long long)c.can_tx_failed, (unsigned long long)c.datagrams_rx,
              (unsigned long long)c.datagrams_oversize, (unsigned long long)c.frames_published,
              (unsigned long long)c.heartbeats, (unsigned long long)c.pps_edges, (unsigned long long)c.clock_disciplined);
  std::printf("v2xloc-firmware: decoded vehicle %llu (invalid %llu) gnss %llu (incomplete %llu) can_rejected %llu unknown_id %llu"
              " ego_scans %llu map_clouds %llu clouds_rejected %llu datagrams_rejected %llu\n",
              (unsigned long long)can.vehicle_inputs, (unsigned long long)can.vehicle_invalid,
              (unsigned long long)can.gnss_inputs, (unsigned long long)can.gnss_incomplete,
              (unsigned long long)can.can_rejected, (unsigned long long)can.can_unknown_id,
              (unsigned long long)d.ego_scans, (unsigned long long)s.map_clouds,
              (unsigned long long)(d.clouds_rejected + s.shares_malformed),
              (unsigned long long)d.datagrams_rejected);
  const trust::VerifierCounters& v = app.decoder().shares().verifier().counters();
  const PeriodCounters& p = app.period_counters();
  std::printf("v2xloc-firmware: trust shares accepted %llu rejected %llu (missing_signature %llu unknown_signer %llu"
              " sender_mismatch %llu too_old %llu future %llu stamp_skew %llu replay %llu pose_mismatch %llu bad_signature %llu"
              " crypto_error %llu)"
              " signatures %llu malformed %llu; ecdsa_runs %llu (checked_on_arrival %llu); wrong_channel %llu"
              " ego_time_rejected %llu ego_frames_held %llu\n",
              (unsigned long long)v.accepted, (unsigned long long)v.rejected(), (unsigned long long)v.missing_signature,
              (unsigned long long)v.unknown_signer, (unsigned long long)v.sender_mismatch, (unsigned long long)v.too_old,
              (unsigned long long)v.future, (unsigned long long)v.stamp_skew, (unsigned long long)v.replay,
              (unsigned long long)v.pose_mismatch, (unsigned long long)v.bad_signature, (unsigned long long)v.crypto_error, (unsigned long long)v.signatures_rx,
              (unsigned long long)v.signatures_malformed, (unsigned long long)s.signature_verifications,
              (unsigned long long)s.signatures_checked_on_arrival, (unsigned long long)d.wrong_channel,
              (unsigned long long)d.ego_time_rejected, (unsigned long long)p.ego_frames_held);
  std::printf("v2xloc-firmware: can_repeated %llu can_counter_gaps %llu gnss_position_dropped %llu gnss_time_rejected %llu"
              " inputs_released_early %llu\n",
              (unsigned long long)can.can_repeated, (unsigned long long)can.can_counter_gaps,
              (unsigned long long)can.gnss_position_dropped, (unsigned long long)c.gnss_time_rejected,
              (unsigned long long)p.inputs_released_early);
  std::printf("v2xloc-firmware: periods %llu periods_without_scan %llu late_scans %llu timer_restarts %llu\n",
              (unsigned long long)p.periods, (unsigned long long)p.periods_without_scan,
              (unsigned long long)p.late_scans, (unsigned long long)p.timer_restarts);
  std::printf("v2xloc-firmware: map fusion of trusted shares: inconsistent %llu (infrastructure %llu) background_mismatch %llu"
              " (off_background_before_signature %llu) held_back %llu no_slot %llu stale %llu; paced (not needed, source's last recent) %llu on arrival (not hashed),"
              " %llu before and %llu after the signature check\n",
              (unsigned long long)p.map_inconsistent, (unsigned long long)p.map_infra_inconsistent,
              (unsigned long long)p.map_background_mismatch, (unsigned long long)s.shares_off_background,
              (unsigned long long)p.map_held_back,
              (unsigned long long)p.map_no_slot, (unsigned long long)p.map_stale,
              (unsigned long long)s.shares_paced_on_arrival, (unsigned long long)s.shares_paced,
              (unsigned long long)p.map_paced);
  const LocalizerCounters& l = g_localizer.counters();
  std::printf("v2xloc-firmware: localizer searches %u (accepted %u confirmed %u inconsistent %u unconstrained %u dropped %u final_icp_paused %u) basin_audits %u"
              " switches %u track_losses %u filter_resets %u reacquisitions_refused %u registrations %u (ok %u fused %u"
              " gate_rejected %u) map_rebuilds %u map_clouds_paced %u\n",
              l.global_searches, l.global_accepted, l.global_confirmed, l.global_inconsistent, l.global_unconstrained,
              l.global_searches_dropped, l.global_final_icp_paused,
              l.basin_audits, l.basin_switches, l.track_losses, l.filter_resets, l.reacquisitions_refused, l.tracking_registrations,
              l.registrations_ok, l.registrations_fused, l.registrations_gate_rejected, l.map_rebuilds, l.map_clouds_paced);
  std::printf("v2xloc-firmware: reassembly fragments %llu frames %llu duplicates %llu stale %llu timed_out %llu evicted %llu"
              " bad_crc %llu truncated %llu malformed %llu over_capacity %llu points_thinned %llu\n",
              (unsigned long long)r.fragments_accepted, (unsigned long long)r.frames_completed,
              (unsigned long long)r.duplicates, (unsigned long long)r.stale_fragments,
              (unsigned long long)r.frames_timed_out, (unsigned long long)r.frames_evicted,
              (unsigned long long)r.bad_crc, (unsigned long long)r.truncated, (unsigned long long)r.malformed,
              (unsigned long long)r.over_capacity, (unsigned long long)r.points_thinned);
  print_imu_counters(app);
}

// ---- Options: command line, or `key=value` lines in --config FILE (the command line wins). ----
struct Options {
  bool emulated = false;
  std::string config;
  int cloud_port = 47200, ego_port = 47201;
  std::string cloud_bind, ego_bind;  // empty: 127.0.0.1 emulated, 0.0.0.0 real
  std::string trust_list;
  std::vector<double> origin;        // LAT,LON,ALT
  long long epoch_ns = 0;
  long long max_frames = 0;          // 0: no limit
  int rcvbuf = 32 << 20;
  // Real backends.
  std::string can_iface = "can0";
  int can_bring_up = 0;
  std::string pps_chip = "gpiochip0", led_chip = "gpiochip0";
  int pps_line = -1, led_line = -1;  // -1: not used
  int imu = 1;                        // open the HID IMU (hidapi, VID:PID of hal/HID_IMU_REPORT.md)
  std::string imu_hidraw;             // its hidraw path instead of VID:PID
  int imu_rate = 200;                 // commanded output rate [Hz]
  // Emulated backends.
  int can_port = 47100, can_peer_port = 47101;
  int pps = 1;
  std::string imu_script;  // HID IMU reports (hal/emulated/hid_script.hpp); empty: no IMU
};

// A dotted IPv4 address the UDP backend accepts.
const CLI::Validator kIpv4 = CLI::Validator(
    [](std::string& text) {
      std::uint32_t address = 0;
      return hal::parse_ipv4(text.c_str(), address) ? std::string() : "want an IPv4 address A.B.C.D, got '" + text + "'";
    },
    "A.B.C.D");

// Returns -1 when the options are complete, else the exit code (0 for --help; 2 for a usage error,
// an unreadable or unknown config entry, or a missing / bad --origin, with the message).
int parse_options(int argc, char** argv, Options& o) {
  CLI::App app{"The v2xloc ECU application: real backends (SocketCAN, UDP, libgpiod) or, with --emulated, CAN over\n"
               "UDP on loopback and a clock driven by the replayer. Prints 'v2xloc-firmware: ready can=PORT\n"
               "cloud=PORT ego=PORT' once the sockets are bound; every counter at exit (SIGINT/SIGTERM).",
               "v2xloc-firmware"};
  // A later value replaces an earlier one (the replayer's arguments, then the caller's extras).
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app.set_config("--config", "", "key=value lines (e.g. origin=48.1374,11.5755,520); the command line wins")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  app.allow_config_extras(false);
  const CLI::Range port(0, 65535);
  app.add_flag("--emulated", o.emulated, "emulated backends for the host replay");
  app.add_option("--origin", o.origin, "required: the local ENU origin of the map and the poses")
      ->delimiter(',')
      ->expected(3)
      ->type_name("LAT,LON,ALT");
  app.add_option("--cloud-port", o.cloud_port, "UDP port of the V2X map shares (0 = ephemeral)")->capture_default_str()->check(port);
  app.add_option("--cloud-bind", o.cloud_bind, "address of the map-share socket")->check(kIpv4);
  app.add_option("--ego-port", o.ego_port, "UDP port of the ego scans (0 = ephemeral)")->capture_default_str()->check(port);
  app.add_option("--ego-bind", o.ego_bind, "address of the ego-scan socket")->check(kIpv4);
  app.add_option("--trust-list", o.trust_list, "provisioned V2X signers; without it every map share is refused")
      ->type_name("FILE");
  app.add_option("--epoch-ns", o.epoch_ns, "Unix ns of localizer t = 0")->capture_default_str()
      ->check(CLI::Range(0LL, std::numeric_limits<long long>::max()));
  app.add_option("--max-frames", o.max_frames, "exit after N published frames (0: no limit)")->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--rcvbuf", o.rcvbuf, "socket receive buffer, bytes")->capture_default_str()->check(CLI::Range(4096, 1 << 30));
  app.add_option("--can-iface", o.can_iface, "real: SocketCAN interface")->capture_default_str();
  app.add_option("--can-bring-up", o.can_bring_up, "real: set the interface up (needs privileges)")->capture_default_str()
      ->check(CLI::Range(0, 1));
  app.add_option("--pps-chip", o.pps_chip, "real: GPIO chip of the PPS line")->capture_default_str();
  app.add_option("--pps-line", o.pps_line, "real: PPS input line (absent: no PPS)")->check(CLI::Range(0, 65535));
  app.add_option("--led-chip", o.led_chip, "real: GPIO chip of the status LED")->capture_default_str();
  app.add_option("--led-line", o.led_line, "real: status LED line (absent: no LED)")->check(CLI::Range(0, 65535));
  app.add_option("--imu", o.imu, "real: open the USB HID IMU (absent device: logged once, run without)")
      ->capture_default_str()->check(CLI::Range(0, 1));
  app.add_option("--imu-hidraw", o.imu_hidraw, "real: the IMU's hidraw path instead of its VID:PID")->type_name("PATH");
  app.add_option("--imu-rate", o.imu_rate, "IMU output rate commanded at start, Hz")->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_option("--imu-script", o.imu_script, "emulated: the IMU's HID reports, '<time_ns> <hex bytes>' lines")
      ->check(CLI::ExistingFile)->type_name("FILE");
  app.add_option("--can-port", o.can_port, "emulated: the firmware's CAN-over-UDP port (0 = ephemeral)")->capture_default_str()
      ->check(port);
  app.add_option("--can-peer-port", o.can_peer_port, "emulated: where CAN replies go")->capture_default_str()->check(port);
  app.add_option("--pps", o.pps, "emulated: scripted PPS edges")->capture_default_str()->check(CLI::Range(0, 1));
  try {
    app.parse(argc, argv);
    // No built-in default: a pose against a guessed origin would be silently wrong.
    if (o.origin.size() != 3) throw CLI::ValidationError("--origin", "LAT,LON,ALT is required (three numbers)");
    if (!(std::abs(o.origin[0]) <= 90.0 && std::abs(o.origin[1]) <= 180.0 && std::abs(o.origin[2]) <= 1e5))
      throw CLI::ValidationError("--origin", "latitude within +-90, longitude within +-180, altitude within +-100 km");
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (o.cloud_bind.empty()) o.cloud_bind = o.emulated ? "127.0.0.1" : "0.0.0.0";
  if (o.ego_bind.empty()) o.ego_bind = o.emulated ? "127.0.0.1" : "0.0.0.0";
  return -1;
}

// ---- Backends: what main() hands the application, and what the exit report reads. ----
struct Backends {
  hal::UdpLink* cloud_link = nullptr;
  hal::UdpLink* ego_link = nullptr;
  hal::UdpLink* can_link = nullptr;      // emulated only
  hal::CanBus* can = nullptr;
  hal::Clock* clock = nullptr;
  hal::GpioLine* pps = nullptr;
  hal::GpioLine* led = nullptr;
  hal::HidDevice* imu = nullptr;
  int poll_fds[4] = {-1, -1, -1, -1};    // cloud socket, CAN socket, PPS events, ego socket
  // Emulation only, for the exit report.
  hal::SimClock* sim_clock = nullptr;
  hal::EmulatedCanBus* emulated_can = nullptr;
  SimTimeCanBus* sim_time_can = nullptr;
  CountingLedLine* counting_led = nullptr;
};

bool open_cloud_link(const Options& options, Backends& b) {
  static hal::UdpLink cloud_link;
  hal::UdpOptions o;
  hal::parse_ipv4(options.cloud_bind.c_str(), o.bind.address);  // checked by parse_options
  o.bind.port = static_cast<std::uint16_t>(options.cloud_port);
  if (cloud_link.open(o) != hal::Status::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: cloud UDP: %s\n", cloud_link.last_error());
    return false;
  }
  force_receive_buffer(cloud_link.fd(), options.rcvbuf);
  b.cloud_link = &cloud_link;
  b.poll_fds[0] = cloud_link.fd();
  // Ego sensors on their own endpoint: the V2X socket never carries an ego scan.
  static hal::UdpLink ego_link;
  hal::UdpOptions e;
  hal::parse_ipv4(options.ego_bind.c_str(), e.bind.address);  // checked by parse_options
  e.bind.port = static_cast<std::uint16_t>(options.ego_port);
  if (ego_link.open(e) != hal::Status::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: ego UDP: %s\n", ego_link.last_error());
    return false;
  }
  force_receive_buffer(ego_link.fd(), options.rcvbuf);
  b.ego_link = &ego_link;
  b.poll_fds[3] = ego_link.fd();
  return true;
}

// One surveyed background file named by the trust list (beside it), read at start-up: refused
// before reading when larger than the format allows, then checked against the signer's entry.
bool load_background(const std::string& list_path, const trust::TrustedSigner& s) {
  const std::string path = (std::filesystem::path(list_path).parent_path() / s.background_file.data()).string();
  if (g_backgrounds.full()) {
    std::fprintf(stderr, "v2xloc-firmware: %s: more backgrounds than the firmware holds (%zu)\n", path.c_str(),
                 BackgroundStore::kUnits);
    return false;
  }
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) {
    std::fprintf(stderr, "v2xloc-firmware: cannot read background %s: %s\n", path.c_str(), ec.message().c_str());
    return false;
  }
  if (size > trust::kMaxBackgroundFileBytes) {
    std::fprintf(stderr, "v2xloc-firmware: %s: %s\n", path.c_str(), trust::to_string(trust::BackgroundStatus::kTooLarge));
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())) || in.peek() != EOF) {
    std::fprintf(stderr, "v2xloc-firmware: cannot read background %s (changed while read?)\n", path.c_str());
    return false;
  }
  const trust::BackgroundStatus status = g_backgrounds.load(s, bytes);
  if (status != trust::BackgroundStatus::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: %s: %s\n", path.c_str(), trust::to_string(status));
    return false;
  }
  return true;
}

// Every background the list names, into g_backgrounds and on to the localizer (after configure).
bool provision_backgrounds(const std::string& list_path, const trust::TrustList& list) {
  for (const trust::TrustedSigner& s : list.view()) {
    if (s.has_background && !load_background(list_path, s)) return false;
  }
  if (g_backgrounds.provision(g_localizer) != g_backgrounds.count()) {
    std::fprintf(stderr, "v2xloc-firmware: the localizer refused a surveyed background\n");
    return false;
  }
  std::size_t cells = 0;
  for (std::size_t i = 0; i < g_backgrounds.count(); ++i) cells += g_backgrounds.background(i).cells.size();
  std::printf("v2xloc-firmware: surveyed backgrounds: %zu loaded, %zu cells (capacity %zu units x %zu)\n",
              g_backgrounds.count(), cells, BackgroundStore::kUnits, BackgroundStore::kCells);
  return true;
}

// The provisioned trust list (--trust-list FILE) and the backgrounds it names, read at start-up
// (heap allowed here).
bool provision_trust(const Options& options) {
  if (options.trust_list.empty()) {
    std::printf("v2xloc-firmware: no trust list: every V2X map share will be refused\n");
    return true;
  }
  const std::string& path = options.trust_list;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "v2xloc-firmware: cannot read trust list %s\n", path.c_str());
    return false;
  }
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  static trust::TrustList list;
  const trust::TrustListParseResult r = trust::parse_trust_list(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()), list);
  if (r.status != trust::TrustListStatus::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: %s:%zu: %s\n", path.c_str(), r.line, trust::to_string(r.status));
    return false;
  }
  g_decoder.provision_trust(list);
  std::size_t infrastructure = 0;
  for (const trust::TrustedSigner& s : list.view()) infrastructure += s.role == trust::SignerRole::kInfrastructure ? 1u : 0u;
  // Unsurveyed infrastructure is trusted on the pose it declares (lists written before surveys).
  std::printf("v2xloc-firmware: trust list: %zu signers, %zu infrastructure, %zu of them surveyed, %zu with a surveyed"
              " background\n", list.count, infrastructure, list.surveyed_count(), list.background_count());
  return provision_backgrounds(path, list);
}

// CAN over UDP on loopback, the SimClock driven by the replayer's sim-time frames, scripted PPS
// edges and a counting LED.
bool open_emulated_backends(const Options& options, std::int64_t epoch_ns, Backends& b) {
  static hal::SimClock sim_clock(0, epoch_ns, hal::SimClock::SleepMode::kExternal);
  static hal::UdpLink can_link;
  static hal::ScriptedGpioLine pps(sim_clock);
  static CountingLedLine led;
  hal::UdpOptions o;
  o.bind.port = static_cast<std::uint16_t>(options.can_port);
  o.has_peer = true;
  o.peer = hal::Ipv4Endpoint{0x7F000001u, static_cast<std::uint16_t>(options.can_peer_port)};
  o.receive_buffer_bytes = 1 << 20;
  if (can_link.open(o) != hal::Status::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: emulated CAN UDP: %s\n", can_link.last_error());
    return false;
  }
  static hal::EmulatedCanBus emulated_can(can_link, sim_clock);
  static SimTimeCanBus sim_time_can(emulated_can, sim_clock);
  b.can_link = &can_link;
  b.can = &sim_time_can;
  b.clock = &sim_clock;
  if (options.pps != 0) {
    script_pps_edges(pps, epoch_ns, 3600LL * 1'000'000'000);  // one hour of edges, at start-up
    b.pps = &pps;
  }
  b.led = &led;
  if (!options.imu_script.empty()) {
    static hal::ScriptedHidDevice imu(sim_clock);
    if (imu.load_script(options.imu_script.c_str()) != hal::Status::kOk) {
      std::fprintf(stderr, "v2xloc-firmware: IMU script %s: not '<time_ns> <hex bytes>' lines in time order\n",
                   options.imu_script.c_str());
      return false;
    }
    std::printf("v2xloc-firmware: IMU: emulated HID device, %zu reports scripted\n", imu.pending_reports());
    b.imu = &imu;
  }
  b.poll_fds[1] = can_link.fd();
  b.sim_clock = &sim_clock;
  b.emulated_can = &emulated_can;
  b.sim_time_can = &sim_time_can;
  b.counting_led = &led;
  return true;
}

bool open_gpio_line(hal::GpiodLine& line, const std::string& chip, long long offset,
                    hal::GpiodLineOptions::Mode mode, const char* what) {
  hal::GpiodLineOptions g;
  g.chip = chip.c_str();
  g.offset = static_cast<unsigned>(offset);
  g.mode = mode;
  if (line.open(g) == hal::Status::kOk) return true;
  std::fprintf(stderr, "v2xloc-firmware: %s: %s\n", what, line.last_error());
  return false;
}

// The USB HID IMU through hidapi; an ECU without one runs without (logged once here).
void open_imu(const Options& options, Backends& b) {
  if (options.imu == 0) return;
  static hal::HidapiDevice imu;
  static const std::string hidraw = options.imu_hidraw;
  hal::HidapiOptions o;
  if (!hidraw.empty()) o.path = hidraw.c_str();
  if (imu.open(o) != hal::Status::kOk) {
    std::printf("v2xloc-firmware: IMU: no HID device (%s): running without an IMU\n", imu.last_error());
    return;
  }
  std::printf("v2xloc-firmware: IMU: HID device open\n");
  b.imu = &imu;
}

// SocketCAN, the Linux clock, and PPS / LED on GPIO lines when their line numbers are given.
bool open_real_backends(const Options& options, Backends& b) {
  static hal::LinuxClock linux_clock;
  static hal::SocketCanBus socketcan;
  static hal::GpiodLine pps, led;
  static const std::string iface = options.can_iface;
  hal::SocketCanOptions o;
  o.interface = iface.c_str();
  o.bring_up = options.can_bring_up != 0;
  if (socketcan.open(o) != hal::Status::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: SocketCAN %s: %s\n", iface.c_str(), socketcan.last_error());
    return false;
  }
  b.can = &socketcan;
  b.clock = &linux_clock;
  b.poll_fds[1] = socketcan.fd();
  if (options.pps_line >= 0) {
    if (!open_gpio_line(pps, options.pps_chip, options.pps_line,
                        hal::GpiodLineOptions::Mode::kEdgeInput, "PPS")) {
      return false;
    }
    b.pps = &pps;
    b.poll_fds[2] = pps.event_fd();
  }
  if (options.led_line >= 0) {
    if (!open_gpio_line(led, options.led_chip, options.led_line,
                        hal::GpiodLineOptions::Mode::kOutput, "LED")) {
      return false;
    }
    b.led = &led;
  }
  open_imu(options, b);
  return true;
}

// Polls until SIGINT/SIGTERM or max_frames published frames (0: no limit); idle polls wait on the
// sockets (or the heartbeat tick). No allocation in here: counted, reported at exit.
void run_loop(FirmwareApp& app, const Backends& b, long long max_frames) {
  pollfd fds[4];
  nfds_t nfds = 0;
  for (int fd : b.poll_fds) {
    if (fd >= 0) fds[nfds++] = pollfd{fd, POLLIN, 0};
  }
  alloc_counter::arm(true);
  while (!g_stop) {
    if (app.poll_once() == 0) poll(fds, nfds, 20);
    if (max_frames > 0 && app.counters().frames_published >= static_cast<unsigned long long>(max_frames)) break;
  }
  alloc_counter::arm(false);
}

void print_exit_report(const FirmwareApp& app, const Backends& b) {
  std::printf("v2xloc-firmware: heap allocations in the main loop: %llu (%llu bytes)\n",
              (unsigned long long)alloc_counter::allocations(), (unsigned long long)alloc_counter::bytes());
  print_counters(app);
  if (b.sim_time_can == nullptr) return;
  std::printf("v2xloc-firmware: sim-time frames %llu (backwards %llu), sim time %.3f s, LED changes %llu\n",
              (unsigned long long)b.sim_time_can->time_frames(), (unsigned long long)b.sim_time_can->time_backwards(),
              b.sim_clock->monotonic_ns() * 1e-9, (unsigned long long)b.counting_led->changes());
  const hal::CanCounters cc = b.emulated_can->counters();
  std::printf("v2xloc-firmware: emulated CAN rx %llu tx %llu malformed %llu\n", (unsigned long long)cc.rx_frames,
              (unsigned long long)cc.tx_frames, (unsigned long long)cc.rx_malformed);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (const int exit_code = parse_options(argc, argv, options); exit_code >= 0) return exit_code;
  const GeodeticOrigin origin = make_geodetic_origin(options.origin[0], options.origin[1], options.origin[2]);
  const std::int64_t epoch_ns = options.epoch_ns;
  std::setvbuf(stdout, nullptr, _IOLBF, 0);

  print_memory();
  configure_localizer(g_localizer, origin);
  g_decoder.set_epoch_ns(epoch_ns);
  static LocalizerAdapter<Localizer> port(g_localizer);

  Backends b;
  if (!open_cloud_link(options, b)) return 1;
  if (!provision_trust(options)) return 1;
  if (!(options.emulated ? open_emulated_backends(options, epoch_ns, b) : open_real_backends(options, b))) return 1;
  FirmwareConfig config;
  config.imu_rate_hz = static_cast<std::uint16_t>(options.imu_rate);
  static FirmwareApp app(FirmwareHal{*b.can, *b.cloud_link, *b.ego_link, *b.clock, b.pps, b.led, b.imu}, g_decoder, port,
                         config);
  if (app.start() != hal::Status::kOk) {
    std::fprintf(stderr, "v2xloc-firmware: CAN filter set-up failed\n");
    return 1;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::printf("v2xloc-firmware: ready can=%u cloud=%u ego=%u mode=%s\n",
              b.can_link != nullptr ? b.can_link->local_endpoint().port : 0u, b.cloud_link->local_endpoint().port,
              b.ego_link->local_endpoint().port,
              options.emulated ? "emulated" : "real");

  run_loop(app, b, options.max_frames);
  print_exit_report(app, b);
  return 0;
}
