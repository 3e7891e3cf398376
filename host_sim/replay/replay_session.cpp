#include "host_sim/replay/replay_session.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <string>
#include <thread>

#include "firmware/wire/period_timer.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "hal/emulated/emulated_can_bus.hpp"
#include "hal/emulated/sim_clock.hpp"
#include "hal/linux/udp_link.hpp"
#include "host_sim/recording/imu_reports.hpp"

namespace v2xloc::sim::replay {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The started firmware process: stdout through a pipe, read by a thread into a string.
class FirmwareProcess {
 public:
  ~FirmwareProcess() { stop(); }

  bool start(const std::string& path, const std::vector<std::string>& args, std::string& error) {
    int fds[2];
    if (pipe(fds) != 0) {
      error = std::string("pipe: ") + std::strerror(errno);
      return false;
    }
    std::vector<std::string> argv_s{path};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    if (pid_ < 0) {
      error = std::string("fork: ") + std::strerror(errno);
      return false;
    }
    if (pid_ == 0) {
      dup2(fds[1], STDOUT_FILENO);
      close(fds[0]);
      close(fds[1]);
      execv(path.c_str(), argv.data());
      std::fprintf(stderr, "exec %s: %s\n", path.c_str(), std::strerror(errno));
      _exit(127);
    }
    close(fds[1]);
    fd_ = fds[0];
    return true;
  }

  // Reads lines until the "ready" line; returns its ports.
  bool wait_ready(double timeout_s, unsigned& can_port, unsigned& cloud_port, unsigned& ego_port, std::string& error) {
    const auto t0 = Clock::now();
    std::string line;
    while (seconds_since(t0) < timeout_s) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char c;
      const ssize_t n = read(fd_, &c, 1);
      if (n <= 0) {
        error = "firmware exited during start-up:\n" + output_;
        return false;
      }
      output_.push_back(c);
      if (c != '\n') {
        line.push_back(c);
        continue;
      }
      if (std::sscanf(line.c_str(), "v2xloc-firmware: ready can=%u cloud=%u ego=%u", &can_port, &cloud_port, &ego_port) >= 2) {
        reader_ = std::thread([this] { drain(); });
        return true;
      }
      line.clear();
    }
    error = "firmware not ready within the start-up timeout:\n" + output_;
    return false;
  }

  // SIGTERM, collect the rest of the output, reap. Returns the exit code (-1 on a signal).
  int stop() {
    if (pid_ <= 0) return exit_code_;
    int status = exited_status_;
    if (!exited_) kill(pid_, SIGTERM);
    if (reader_.joinable()) reader_.join();
    if (!exited_) waitpid(pid_, &status, 0);
    pid_ = -1;
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return exit_code_;
  }
  const std::string& output() const { return output_; }
  // False once the started process has exited (then its status is kept for stop()).
  bool alive() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return true;
    exited_status_ = status;
    exited_ = true;
    return false;
  }

 private:
  void drain() {
    char buf[4096];
    for (;;) {
      const ssize_t n = read(fd_, buf, sizeof buf);
      if (n <= 0) return;
      output_.append(buf, static_cast<std::size_t>(n));
    }
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  int exit_code_ = -1;
  bool exited_ = false;
  int exited_status_ = 0;
  std::string output_;
  std::thread reader_;
};

// Non-blocking sends that retry briefly when the socket buffer is momentarily full.
template <class SendFn>
bool send_with_retry(SendFn&& send, std::size_t& retries) {
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const hal::Status s = send();
    if (s == hal::Status::kOk) return true;
    if (s != hal::Status::kWouldBlock) return false;
    ++retries;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  return false;
}

// The pose and diagnostic frames of replayed frame i as they arrive: complete once the odometry
// attitude (sent last) names the firmware's period and the pose (position, attitude with that frame
// counter, sigma) and the other diagnostics (those with a frame counter naming it) decoded before it.
// `period`: the firmware's period index (it counts the periods it closed, with or without a scan).
class FrameCollector {
 public:
  FrameCollector(int i, std::uint32_t period, double t, ReplayResult& result)
      : result_(result), counter_(static_cast<std::uint16_t>(period & 0xFFFFu)) {
    frame_.frame = i;
    frame_.t = t;
  }

  void take(const hal::CanFrame& f) {
    std::size_t* pose_errors = &result_.pose_decode_errors;
    std::size_t* diagnostic_errors = &result_.diagnostic_decode_errors;
    switch (f.id) {
      case protocol::kHeartbeatId: ++result_.heartbeats; break;
      case protocol::kPosePositionId:
        have_position_ = keep(frame_.pose.position, f, frame_.position, pose_errors);
        break;
      case protocol::kPoseAttitudeId:
        have_attitude_ = keep(frame_.pose.attitude, f, frame_.attitude, nullptr) &&
                         frame_.attitude.frame_counter == counter_;
        break;
      case protocol::kPoseSigmaId: have_sigma_ = keep(frame_.pose.sigma, f, frame_.sigma, pose_errors); break;
      case protocol::kRegistrationPositionId:
        have_reg_position_ =
            keep(frame_.diagnostics.registration_position, f, frame_.registration_position, diagnostic_errors);
        break;
      case protocol::kRegistrationQualityId:
        have_reg_quality_ =
            keep(frame_.diagnostics.registration_quality, f, frame_.registration_quality, diagnostic_errors) &&
            frame_.registration_quality.frame_counter == counter_;
        break;
      case protocol::kGateDecisionId:
        have_gate_ = keep(frame_.diagnostics.gate, f, frame_.gate, diagnostic_errors) &&
                     frame_.gate.frame_counter == counter_;
        break;
      case protocol::kOdometryPositionId:
        have_odom_position_ =
            keep(frame_.diagnostics.odometry_position, f, frame_.odometry_position, diagnostic_errors);
        break;
      case protocol::kOdometryAttitudeId:
        done_ = keep(frame_.diagnostics.odometry_attitude, f, frame_.odometry_attitude, diagnostic_errors) &&
                frame_.odometry_attitude.frame_counter == counter_ && have_position_ && have_attitude_ && have_sigma_ &&
                have_reg_position_ && have_reg_quality_ && have_gate_ && have_odom_position_;
        break;
      default: break;
    }
  }
  bool done() const { return done_; }
  const ReplayedFrame& frame() const { return frame_; }

 private:
  // The frame as received in `slot`, decoded; a decode failure counted in `errors` (when given).
  template <class Decoded>
  static bool keep(hal::CanFrame& slot, const hal::CanFrame& f, Decoded& decoded, std::size_t* errors) {
    slot = f;
    const bool ok = protocol::unpack(f, decoded) == protocol::DecodeStatus::kOk;
    if (!ok && errors != nullptr) ++*errors;
    return ok;
  }

  ReplayResult& result_;
  const std::uint16_t counter_;
  ReplayedFrame frame_;
  bool have_position_ = false, have_attitude_ = false, have_sigma_ = false, done_ = false;
  bool have_reg_position_ = false, have_reg_quality_ = false, have_gate_ = false, have_odom_position_ = false;
};

// One replay: the sockets, the started firmware (or the ports of a running one), the event
// stream; frame by frame, send the events and wait for the frame's pose and diagnostics.
class Lockstep {
 public:
  Lockstep(const RecordingReader& reader, const ReplayOptions& options, ReplayResult& result)
      : reader_(reader), options_(options), result_(result), can_(can_link_, stamp_clock_) {}

  bool run(std::string& error) {
    if (!stream_.open(reader_, options_.stream, error) || !open_sockets(error) || !connect_firmware(error)) return false;
    std::vector<WireEvent> events;
    for (int i = 0; i < stream_.frame_count(); ++i) {
      events.clear();
      if (!stream_.next_frame(i, events, error) || !send_events(i, events, error)) return finish(false, error);
      // A frame whose scan was never sent (lidar-blind) gets the period the timer closes at its stamp.
      const bool scan_sent = !events.empty() && events.back().kind == WireEvent::Kind::kEgoScan;
      if (!scan_sent) {
        ++result_.frames_without_scan;
        blind_.push_back(i);
      }
    }
    // Frames whose deadline the recording's last input did not pass.
    result_.frames_without_pose += static_cast<int>(blind_.size());
    return finish(true, error);
  }

 private:
  double localizer_t(std::int64_t time_ns) const {
    return firmware::localizer_time_s(stream_.epoch_ns() + time_ns, stream_.epoch_ns());
  }

  // After a CAN frame: the periods the firmware's timer closes on its stamp (period_timer.hpp, the
  // same rule), each awaited before anything else is sent.
  bool after_can(std::int64_t time_ns, std::string& error) {
    timer_.on_input(localizer_t(time_ns));
    double t = 0.0;
    while (timer_.next_due(t)) {
      if (!await_period_without_scan(t, error)) return false;
    }
    return true;
  }

  // After frame i's ego scan: the periods its stamp shows were skipped, then its own (none when late).
  bool after_scan(int i, std::int64_t time_ns, std::string& error) {
    timer_.on_scan();
    if (i == options_.stream.faults.ego_time_jump_frame) {  // refused for its stamp: a held period
      timer_.closed_by_refused_scan();
      return await_frame(i, error);
    }
    const double ts = localizer_t(time_ns);
    double t = 0.0;
    while (timer_.next_skipped(ts, t)) {
      if (!await_period_without_scan(t, error)) return false;
    }
    if (timer_.late(ts)) {
      ++result_.late_scans;
      ++result_.frames_without_pose;
      return true;
    }
    timer_.closed_by_scan(ts);
    return await_frame(i, error);
  }

  // A period closed without a scan at t: the recording frame without a scan nearest to it (none:
  // awaited, not reported); frames without a scan before it got no period (a timer restart).
  bool await_period_without_scan(double t, std::string& error) {
    const double half = 0.5 * timer_.params().period_s;
    while (!blind_.empty() && reader_.frame_time(blind_.front()) < t - half) {
      blind_.pop_front();
      ++result_.frames_without_pose;
    }
    ++result_.periods_without_scan;
    int frame = -1;
    if (!blind_.empty() && reader_.frame_time(blind_.front()) <= t + half) {
      frame = blind_.front();
      blind_.pop_front();
    }
    return await_frame(frame, error);
  }

  bool open_sockets(std::string& error) {
    if (!hal::parse_ipv4(options_.host.c_str(), host_)) {
      error = "bad host address " + options_.host;
      return false;
    }
    hal::UdpOptions can_options;
    can_options.bind = hal::Ipv4Endpoint{0x7F000001u, options_.local_can_port};
    can_options.receive_buffer_bytes = 1 << 20;
    if (can_link_.open(can_options) != hal::Status::kOk) {
      error = std::string("CAN UDP socket: ") + can_link_.last_error();
      return false;
    }
    hal::UdpOptions cloud_options;
    cloud_options.bind = hal::Ipv4Endpoint{0x7F000001u, 0};
    if (cloud_link_.open(cloud_options) != hal::Status::kOk) {
      error = std::string("cloud UDP socket: ") + cloud_link_.last_error();
      return false;
    }
    if (ego_link_.open(cloud_options) != hal::Status::kOk) {
      error = std::string("ego UDP socket: ") + ego_link_.last_error();
      return false;
    }
    return true;
  }

  // fork/exec the firmware on ephemeral ports, provisioned with the recording's trust list and
  // origin, and read its ports from its "ready" line.
  bool start_firmware(unsigned& can_port, unsigned& cloud_port, unsigned& ego_port, std::string& error) {
    char origin[128];
    std::snprintf(origin, sizeof origin, "%.10f,%.10f,%.4f", reader_.origin_lat_deg(), reader_.origin_lon_deg(),
                  reader_.origin_alt_m());
    std::vector<std::string> args{"--emulated",
                                  "--can-port", "0",
                                  "--cloud-port", "0",
                                  "--ego-port", "0",
                                  "--trust-list", reader_.trust_list_path(),
                                  "--can-peer-port", std::to_string(can_link_.local_endpoint().port),
                                  "--epoch-ns", std::to_string(stream_.epoch_ns()),
                                  "--origin", origin};
    if (!stream_.imu_reports().empty()) {
      if (!write_imu_script(error)) return false;
      args.insert(args.end(), {"--imu-script", imu_script_.path});
    }
    args.insert(args.end(), options_.firmware_args.begin(), options_.firmware_args.end());
    if (!process_.start(options_.firmware_path, args, error)) return false;
    if (!process_.wait_ready(options_.startup_timeout_s, can_port, cloud_port, ego_port, error)) {
      result_.firmware_exit_code = process_.stop();
      return false;
    }
    return true;
  }

  // The stream's IMU reports (faults applied) as the emulated firmware's HID script, in a
  // temporary file removed with the session.
  bool write_imu_script(std::string& error) {
    char path[] = "/tmp/v2xloc-imu-XXXXXX";
    const int fd = mkstemp(path);
    if (fd < 0) {
      error = std::string("IMU script: ") + std::strerror(errno);
      return false;
    }
    imu_script_.path = path;
    const std::string text = imu_reports_text(stream_.imu_reports());
    const bool written = write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
    close(fd);
    if (!written) error = "IMU script: short write to " + imu_script_.path;
    return written;
  }

  bool connect_firmware(std::string& error) {
    unsigned fw_can = options_.firmware_can_port, fw_cloud = options_.firmware_cloud_port,
             fw_ego = options_.firmware_ego_port;
    if (!options_.firmware_path.empty() && !start_firmware(fw_can, fw_cloud, fw_ego, error)) return false;
    if (fw_can == 0 || fw_cloud == 0) {
      error = "no firmware ports (start one with --firmware or give --connect HOST:CAN,CLOUD)";
      return false;
    }
    can_link_.set_peer(hal::Ipv4Endpoint{host_, static_cast<std::uint16_t>(fw_can)});
    cloud_link_.set_peer(hal::Ipv4Endpoint{host_, static_cast<std::uint16_t>(fw_cloud)});
    // Ego scans on the firmware's ego endpoint (a firmware without one: the cloud port).
    ego_link_.set_peer(hal::Ipv4Endpoint{host_, static_cast<std::uint16_t>(fw_ego != 0 ? fw_ego : fw_cloud)});
    can_.accept_all();
    return true;
  }

  bool send_can(const hal::CanFrame& f) {
    if (!send_with_retry([&] { return can_.send(f); }, result_.send_retries)) return false;
    ++result_.can_frames_sent;
    return true;
  }
  bool send_time(std::int64_t t) {
    if (t <= last_time_sent_) return true;  // the clock never goes back; equal times need no frame
    last_time_sent_ = t;
    return send_can(firmware::make_sim_time_frame(t));
  }

  // Frame i's events in stream order, each preceded by the sim-time frame of its stamp.
  bool send_events(int i, const std::vector<WireEvent>& events, std::string& error) {
    for (const WireEvent& ev : events) {
      bool ok = true;
      if (ev.kind == WireEvent::Kind::kImuReport) continue;  // the firmware's HID script carries them
      if (ev.kind == WireEvent::Kind::kCan) {
        ok = send_time(ev.time_ns) && send_can(ev.can);
      } else {
        if (ev.kind == WireEvent::Kind::kEgoScan) ok = send_time(ev.time_ns);
        for (const auto& d : ev.datagrams) {
          if (!ok) break;
          hal::UdpLink& link = ev.kind == WireEvent::Kind::kEgoScan ? ego_link_ : cloud_link_;
          ok = send_with_retry([&] { return link.send(d); }, result_.send_retries);
          ++result_.datagrams_sent;
        }
      }
      if (!ok) {
        error = "send failed at frame " + std::to_string(i);
        return false;
      }
      if (ev.kind == WireEvent::Kind::kCan && !after_can(ev.time_ns, error)) return false;
      if (ev.kind == WireEvent::Kind::kEgoScan && !after_scan(i, ev.time_ns, error)) return false;
    }
    return true;
  }

  // Lockstep: the CAN frames until the next period's pose and diagnostics are complete, the frame
  // timeout passes or the started firmware exits. i: its recording frame (reported), or -1.
  bool await_frame(int i, std::string& error) {
    const std::uint32_t period = periods_++;
    FrameCollector collector(i, period, i >= 0 ? reader_.frame_time(i) : 0.0, result_);
    const auto wait0 = Clock::now();
    while (!collector.done()) {
      hal::CanRxFrame rx;
      const hal::Status s = can_.receive(rx);
      if (s == hal::Status::kWouldBlock) {
        if (seconds_since(wait0) > options_.frame_timeout_s) break;
        if (!options_.firmware_path.empty() && !process_.alive()) {
          error = "firmware exited while replaying frame " + std::to_string(i);
          return false;
        }
        pollfd p{can_link_.fd(), POLLIN, 0};
        poll(&p, 1, 50);
        continue;
      }
      if (s == hal::Status::kOk && !rx.error) collector.take(rx.frame);
    }
    if (!collector.done()) {
      ++result_.timeouts;
      error = "timeout waiting for the pose and diagnostic frames of frame " + std::to_string(i) + " (period " +
              std::to_string(period) + ", " + std::to_string(options_.frame_timeout_s) + " s)";
      return false;
    }
    if (i >= 0) report(collector.frame());
    return true;
  }

  void report(const ReplayedFrame& frame) {
    result_.frames.push_back(frame);
    if (options_.on_frame) options_.on_frame(frame);
    if (options_.verbose) {
      std::fprintf(stderr, "frame %4d  x %9.3f y %9.3f yaw %7.4f  sigma %.3f  flags %d%d%d%d\n", frame.frame,
                   frame.position.x_m, frame.position.y_m, frame.attitude.yaw_rad, frame.sigma.sigma_x_m,
                   frame.position.flags.pose_valid, frame.position.flags.registration_valid,
                   frame.position.flags.gnss_used, frame.position.flags.degraded);
    }
  }

  // The stream's counters, the started firmware stopped (its output and exit code kept), the wall
  // time; a firmware exiting with a non-zero code fails a replay that succeeded.
  bool finish(bool ok, std::string& error) {
    result_.stream_stats = stream_.stats();
    if (!options_.firmware_path.empty()) {
      result_.firmware_exit_code = process_.stop();
      result_.firmware_output = process_.output();
      if (ok && result_.firmware_exit_code != 0) {
        error = "firmware exited with code " + std::to_string(result_.firmware_exit_code);
        ok = false;
      }
    }
    result_.wall_seconds = seconds_since(t0_);
    return ok;
  }

  const RecordingReader& reader_;
  const ReplayOptions& options_;
  ReplayResult& result_;
  const Clock::time_point t0_ = Clock::now();
  EventStream stream_;
  std::uint32_t host_ = 0;
  hal::UdpLink can_link_, cloud_link_, ego_link_;
  hal::SimClock stamp_clock_;  // our receive stamps are irrelevant; only the frames matter
  hal::EmulatedCanBus can_;
  FirmwareProcess process_;
  std::int64_t last_time_sent_ = -1;
  firmware::PeriodTimer timer_{};  // the firmware's period timer, run on the events sent
  std::uint32_t periods_ = 0;      // periods the firmware closed
  std::deque<int> blind_;          // frames without a scan, waiting for their period
  struct TempFile {
    std::string path;
    ~TempFile() {
      if (!path.empty()) std::remove(path.c_str());
    }
  } imu_script_;
};

}  // namespace

bool replay_recording(const RecordingReader& reader, const ReplayOptions& options, ReplayResult& result,
                      std::string& error) {
  result = ReplayResult{};
  return Lockstep(reader, options, result).run(error);
}

StampedTrajectory pose_frames_to_trajectory(const std::vector<ReplayedFrame>& frames) {
  StampedTrajectory out;
  out.reserve(frames.size());
  for (const ReplayedFrame& f : frames) {
    StampedPose p;
    p.t = f.t;
    p.position = Eigen::Vector3d(f.position.x_m, f.position.y_m, f.attitude.z_m);
    p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(f.attitude.yaw_rad, Eigen::Vector3d::UnitZ()));
    out.push_back(p);
  }
  return out;
}

StampedTrajectory ground_truth_trajectory(const RecordingReader& reader) {
  StampedTrajectory out;
  for (const TimedPose& g : reader.ground_truth()) {
    StampedPose p;
    p.t = g.t;
    p.position = g.pose.translation();
    p.orientation = Eigen::Quaterniond(g.pose.rotation());
    out.push_back(p);
  }
  return out;
}

}  // namespace v2xloc::sim::replay
