#include "host_sim/replay/replay_session.hpp"

#include <fstream>

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <thread>

#include "firmware/wire/wire_conventions.hpp"
#include "hal/emulated/emulated_can_bus.hpp"
#include "hal/emulated/sim_clock.hpp"
#include "hal/linux/udp_link.hpp"

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

}  // namespace

bool replay_recording(const RecordingReader& reader, const ReplayOptions& options, ReplayResult& result,
                      std::string& error) {
  result = ReplayResult{};
  const auto t0 = Clock::now();
  EventStream stream;
  if (!stream.open(reader, options.stream, error)) return false;

  std::uint32_t host = 0;
  if (!hal::parse_ipv4(options.host.c_str(), host)) {
    error = "bad host address " + options.host;
    return false;
  }
  hal::UdpLink can_link, cloud_link;
  hal::UdpOptions can_options;
  can_options.bind = hal::Ipv4Endpoint{0x7F000001u, options.local_can_port};
  can_options.receive_buffer_bytes = 1 << 20;
  if (can_link.open(can_options) != hal::Status::kOk) {
    error = std::string("CAN UDP socket: ") + can_link.last_error();
    return false;
  }
  hal::UdpOptions cloud_options;
  cloud_options.bind = hal::Ipv4Endpoint{0x7F000001u, 0};
  if (cloud_link.open(cloud_options) != hal::Status::kOk) {
    error = std::string("cloud UDP socket: ") + cloud_link.last_error();
    return false;
  }

  hal::UdpLink ego_link;
  if (ego_link.open(cloud_options) != hal::Status::kOk) {
    error = std::string("ego UDP socket: ") + ego_link.last_error();
    return false;
  }
  FirmwareProcess process;
  unsigned fw_can = options.firmware_can_port, fw_cloud = options.firmware_cloud_port, fw_ego = options.firmware_ego_port;
  // The firmware is provisioned with the recording's trust list.
  const std::string trust_path = reader.trust_list_path();
  if (!options.firmware_path.empty()) {
    char origin[128];
    std::snprintf(origin, sizeof origin, "%.10f,%.10f,%.4f", reader.origin_lat_deg(), reader.origin_lon_deg(),
                  reader.origin_alt_m());
    std::vector<std::string> args{"--emulated",
                                  "--can-port", "0",
                                  "--cloud-port", "0",
                                  "--ego-port", "0",
                                  "--trust-list", trust_path,
                                  "--can-peer-port", std::to_string(can_link.local_endpoint().port),
                                  "--epoch-ns", std::to_string(stream.epoch_ns()),
                                  "--origin", origin};
    args.insert(args.end(), options.firmware_args.begin(), options.firmware_args.end());
    if (!process.start(options.firmware_path, args, error)) return false;
    if (!process.wait_ready(options.startup_timeout_s, fw_can, fw_cloud, fw_ego, error)) {
      result.firmware_exit_code = process.stop();
      return false;
    }
  }
  if (fw_can == 0 || fw_cloud == 0) {
    error = "no firmware ports (start one with --firmware or give --connect HOST:CAN,CLOUD)";
    return false;
  }
  can_link.set_peer(hal::Ipv4Endpoint{host, static_cast<std::uint16_t>(fw_can)});
  cloud_link.set_peer(hal::Ipv4Endpoint{host, static_cast<std::uint16_t>(fw_cloud)});
  // Ego scans on the firmware's ego endpoint (a firmware without one: the cloud port).
  ego_link.set_peer(hal::Ipv4Endpoint{host, static_cast<std::uint16_t>(fw_ego != 0 ? fw_ego : fw_cloud)});
  hal::SimClock stamp_clock;  // our receive stamps are irrelevant; only the frames matter
  hal::EmulatedCanBus can(can_link, stamp_clock);
  can.accept_all();

  auto finish = [&](bool ok) {
    result.stream_stats = stream.stats();
    if (!options.firmware_path.empty()) {
      result.firmware_exit_code = process.stop();
      result.firmware_output = process.output();
      if (ok && result.firmware_exit_code != 0) {
        error = "firmware exited with code " + std::to_string(result.firmware_exit_code);
        ok = false;
      }
    }
    result.wall_seconds = seconds_since(t0);
    return ok;
  };

  std::int64_t last_time_sent = -1;
  auto send_can = [&](const hal::CanFrame& f) {
    if (!send_with_retry([&] { return can.send(f); }, result.send_retries)) return false;
    ++result.can_frames_sent;
    return true;
  };
  auto send_time = [&](std::int64_t t) {
    if (t <= last_time_sent) return true;  // the clock never goes back; equal times need no frame
    last_time_sent = t;
    return send_can(firmware::make_sim_time_frame(t));
  };

  std::vector<WireEvent> events;
  for (int i = 0; i < stream.frame_count(); ++i) {
    events.clear();
    if (!stream.next_frame(i, events, error)) return finish(false);
    for (const WireEvent& ev : events) {
      bool ok = true;
      if (ev.kind == WireEvent::Kind::kCan) {
        ok = send_time(ev.time_ns) && send_can(ev.can);
      } else {
        if (ev.kind == WireEvent::Kind::kEgoScan) ok = send_time(ev.time_ns);
        for (const auto& d : ev.datagrams) {
          if (!ok) break;
          hal::UdpLink& link = ev.kind == WireEvent::Kind::kEgoScan ? ego_link : cloud_link;
          ok = send_with_retry([&] { return link.send(d); }, result.send_retries);
          ++result.datagrams_sent;
        }
      }
      if (!ok) {
        error = "send failed at frame " + std::to_string(i);
        return finish(false);
      }
    }

    // Lockstep: wait for this frame's pose (position, attitude with frame counter i, sigma) and
    // diagnostics (the frames with a frame counter must name i; odometry attitude comes last).
    ReplayedFrame frame;
    frame.frame = i;
    frame.t = reader.frame_time(i);
    const auto counter_i = static_cast<std::uint16_t>(i & 0xFFFF);
    bool have_position = false, have_attitude = false, have_sigma = false, done = false;
    bool have_reg_position = false, have_reg_quality = false, have_gate = false, have_odom_position = false;
    auto diagnostic = [&](hal::CanFrame& slot, const hal::CanFrame& f, auto& decoded) {
      slot = f;
      const bool ok = protocol::unpack(f, decoded) == protocol::DecodeStatus::kOk;
      if (!ok) ++result.diagnostic_decode_errors;
      return ok;
    };
    const auto wait0 = Clock::now();
    while (!done) {
      hal::CanRxFrame rx;
      const hal::Status s = can.receive(rx);
      if (s == hal::Status::kWouldBlock) {
        if (seconds_since(wait0) > options.frame_timeout_s) break;
        if (!options.firmware_path.empty() && !process.alive()) {
          error = "firmware exited while replaying frame " + std::to_string(i);
          return finish(false);
        }
        pollfd p{can_link.fd(), POLLIN, 0};
        poll(&p, 1, 50);
        continue;
      }
      if (s != hal::Status::kOk || rx.error) continue;
      switch (rx.frame.id) {
        case protocol::kHeartbeatId: ++result.heartbeats; break;
        case protocol::kPosePositionId:
          frame.pose.position = rx.frame;
          have_position = protocol::unpack(rx.frame, frame.position) == protocol::DecodeStatus::kOk;
          if (!have_position) ++result.pose_decode_errors;
          break;
        case protocol::kPoseAttitudeId:
          frame.pose.attitude = rx.frame;
          have_attitude = protocol::unpack(rx.frame, frame.attitude) == protocol::DecodeStatus::kOk &&
                          frame.attitude.frame_counter == static_cast<std::uint16_t>(i & 0xFFFF);
          break;
        case protocol::kPoseSigmaId:
          frame.pose.sigma = rx.frame;
          have_sigma = protocol::unpack(rx.frame, frame.sigma) == protocol::DecodeStatus::kOk;
          if (!have_sigma) ++result.pose_decode_errors;
          break;
        case protocol::kRegistrationPositionId:
          have_reg_position = diagnostic(frame.diagnostics.registration_position, rx.frame, frame.registration_position);
          break;
        case protocol::kRegistrationQualityId:
          have_reg_quality = diagnostic(frame.diagnostics.registration_quality, rx.frame, frame.registration_quality) &&
                             frame.registration_quality.frame_counter == counter_i;
          break;
        case protocol::kGateDecisionId:
          have_gate = diagnostic(frame.diagnostics.gate, rx.frame, frame.gate) && frame.gate.frame_counter == counter_i;
          break;
        case protocol::kOdometryPositionId:
          have_odom_position = diagnostic(frame.diagnostics.odometry_position, rx.frame, frame.odometry_position);
          break;
        case protocol::kOdometryAttitudeId:
          done = diagnostic(frame.diagnostics.odometry_attitude, rx.frame, frame.odometry_attitude) &&
                 frame.odometry_attitude.frame_counter == counter_i && have_position && have_attitude && have_sigma &&
                 have_reg_position && have_reg_quality && have_gate && have_odom_position;
          break;
        default: break;
      }
    }
    if (!done) {
      ++result.timeouts;
      error = "timeout waiting for the pose and diagnostic frames of frame " + std::to_string(i) + " (" +
              std::to_string(options.frame_timeout_s) + " s)";
      return finish(false);
    }
    result.frames.push_back(frame);
    if (options.on_frame) options.on_frame(frame);
    if (options.verbose) {
      std::fprintf(stderr, "frame %4d  x %9.3f y %9.3f yaw %7.4f  sigma %.3f  flags %d%d%d%d\n", i, frame.position.x_m,
                   frame.position.y_m, frame.attitude.yaw_rad, frame.sigma.sigma_x_m, frame.position.flags.pose_valid,
                   frame.position.flags.registration_valid, frame.position.flags.gnss_used,
                   frame.position.flags.degraded);
    }
  }
  return finish(true);
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
