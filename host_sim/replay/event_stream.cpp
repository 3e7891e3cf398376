#include "host_sim/replay/event_stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "host_sim/canlog/candump_log.hpp"

namespace v2xloc::sim::replay {
namespace {

std::int64_t seconds_to_ns(double s) { return std::llround(s * 1e9); }

protocol::SensorPose to_sensor_pose(const Eigen::Isometry3d& T) {
  protocol::SensorPose p;
  const Eigen::Quaterniond q(T.rotation());
  for (int k = 0; k < 3; ++k) p.position_m[k] = T.translation()[k];
  p.quaternion_xyzw[0] = q.x();
  p.quaternion_xyzw[1] = q.y();
  p.quaternion_xyzw[2] = q.z();
  p.quaternion_xyzw[3] = q.w();
  return p;
}

// Trailing index of a sensor name after `prefix` ("infra_2" -> 2, "agent_1_lidar" -> 1).
bool index_after(const std::string& name, const std::string& prefix, std::uint32_t& index) {
  if (name.rfind(prefix, 0) != 0 || name.size() == prefix.size()) return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(name.c_str() + prefix.size(), &end, 10);
  if (end == name.c_str() + prefix.size()) return false;
  index = static_cast<std::uint32_t>(v);
  return true;
}

}  // namespace

bool EventStream::sender_id_for(const MapCloudInfo& info, std::uint32_t& sender_id) {
  std::uint32_t k = 0;
  if (info.kind == "infra" && index_after(info.sensor, "infra_", k) &&
      k < firmware::kAgentSenderBase - firmware::kInfraSenderBase) {
    sender_id = firmware::kInfraSenderBase + k;
    return true;
  }
  if (info.kind == "agent" && index_after(info.sensor, "agent_", k)) {
    sender_id = firmware::kAgentSenderBase + k;
    return true;
  }
  return false;
}

bool EventStream::open(const RecordingReader& reader, const EventStreamConfig& config, std::string& error) {
  *this = EventStream{};
  reader_ = &reader;
  config_ = config;
  frame_count_ = reader.frame_count();
  if (config.max_frames >= 0) frame_count_ = std::min(frame_count_, config.max_frames);
  // Whole microseconds, so candump stamps (us) map to exact recording nanoseconds.
  epoch_ns_ = std::llround(reader.time_origin_unix() * 1e6) * 1000;
  const std::string log = reader.can_log_path();
  if (!log.empty()) {
    const CandumpLog parsed = read_candump_file(log);
    if (!parsed.errors.empty()) {
      error = log + ":" + std::to_string(parsed.errors.front().line_number) + ": " + parsed.errors.front().message;
      return false;
    }
    can_.reserve(parsed.records.size());
    for (const CandumpRecord& r : parsed.records) can_.push_back({r.timestamp_us * 1000 - epoch_ns_, r.frame});
  }
  for (const MapCloudInfo& c : reader.map_clouds()) {
    std::uint32_t id = 0;
    if (!sender_id_for(c, id)) {
      error = "map cloud with unknown sensor name: " + c.sensor + " (" + c.kind + ")";
      return false;
    }
  }
  return true;
}

std::int64_t EventStream::frame_time_ns(int i) const { return seconds_to_ns(reader_->frame_time(i)); }

bool EventStream::fragment(protocol::CloudMessageType type, std::uint32_t sender_id, std::uint32_t seq,
                           std::int64_t stamp_ns, const Eigen::Isometry3d& pose, const cloud_io::PointCloud& cloud,
                           bool with_times, WireEvent& ev, std::string& error) const {
  std::vector<float> xyz;
  xyz.reserve(cloud.points.size() * 3);
  for (const Eigen::Vector3f& p : cloud.points) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  std::vector<std::uint16_t> times;
  if (with_times && cloud.has_time()) {
    times.reserve(cloud.time.size());
    for (const float t : cloud.time) {
      // u16 ticks of protocol::kPointTimeTick after the stamp (WIRE_FORMATS.md): 262 ms span.
      const double ticks = std::nearbyint(static_cast<double>(t) / protocol::kPointTimeTick);
      if (ticks > 65535.0 || ticks < 0.0) ++ev.times_clamped;
      times.push_back(static_cast<std::uint16_t>(std::clamp(ticks, 0.0, 65535.0)));
    }
  }
  protocol::CloudFrameInfo info;
  info.type = type;
  info.sender_id = sender_id;
  info.sensor_id = 0;
  info.frame_seq = seq;
  info.timestamp_ns = static_cast<std::uint64_t>(epoch_ns_ + stamp_ns);
  info.pose = to_sensor_pose(pose);
  info.scale_m = config_.scale_m;
  info.width = protocol::CoordWidth::kInt16;
  protocol::PointCloudFragmenter fragmenter;
  protocol::CloudPointsView view{xyz, {}, times};
  const protocol::CloudStatus s = fragmenter.begin(info, view, config_.max_datagram_bytes);
  if (s != protocol::CloudStatus::kOk) {
    error = std::string("fragmenter: ") + protocol::to_string(s);
    return false;
  }
  std::vector<std::uint8_t> buffer(config_.max_datagram_bytes);
  for (;;) {
    std::size_t written = 0;
    const protocol::CloudStatus n = fragmenter.next(buffer, written);
    if (n == protocol::CloudStatus::kDone) break;
    if (n != protocol::CloudStatus::kOk) {
      error = std::string("fragmenter: ") + protocol::to_string(n);
      return false;
    }
    ev.datagrams.emplace_back(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(written));
  }
  ev.sender_id = sender_id;
  ev.points_sent = fragmenter.total_points();
  ev.points_dropped = fragmenter.dropped_out_of_range() + fragmenter.dropped_non_finite();
  return true;
}

bool EventStream::next_frame(int i, std::vector<WireEvent>& out, std::string& error) {
  if (i != next_frame_ || i >= frame_count_) {
    error = "frames must be requested in order (expected " + std::to_string(next_frame_) + ", got " + std::to_string(i) + ")";
    return false;
  }
  ++next_frame_;
  const std::int64_t t_i = frame_time_ns(i);

  for (; next_can_ < can_.size() && can_[next_can_].time_ns <= t_i; ++next_can_) {
    WireEvent ev;
    ev.kind = WireEvent::Kind::kCan;
    ev.time_ns = can_[next_can_].time_ns;
    ev.can = can_[next_can_].frame;
    out.push_back(std::move(ev));
    ++stats_.can_frames;
  }

  const auto& clouds = reader_->map_clouds();
  for (; next_cloud_ < clouds.size() && seconds_to_ns(clouds[next_cloud_].stamp) <= t_i; ++next_cloud_) {
    const MapCloudInfo& info = clouds[next_cloud_];
    std::uint32_t id = 0;
    sender_id_for(info, id);
    cloud_io::PointCloud cloud;
    if (!reader_->load_map_cloud(info, cloud, error)) return false;
    if (cloud_seq_.size() <= id) cloud_seq_.resize(id + 1, 0);
    WireEvent ev;
    ev.kind = WireEvent::Kind::kMapCloud;
    ev.time_ns = seconds_to_ns(info.stamp);
    if (!fragment(protocol::CloudMessageType::kMapShare, id, cloud_seq_[id]++, ev.time_ns, info.sensor_pose, cloud,
                  false, ev, error)) {
      return false;
    }
    stats_.points_dropped += ev.points_dropped;
    stats_.datagrams += ev.datagrams.size();
    ++stats_.map_clouds;
    out.push_back(std::move(ev));
  }

  cloud_io::PointCloud scan;
  if (!reader_->ego_scan(i, scan, error)) return false;
  WireEvent ev;
  ev.kind = WireEvent::Kind::kEgoScan;
  ev.time_ns = t_i;
  ev.frame = i;
  if (!fragment(protocol::CloudMessageType::kEgoScan, firmware::kEgoSenderId, static_cast<std::uint32_t>(i), t_i,
                reader_->ego_lidar_mount(), scan, config_.ego_point_times, ev, error)) {
    return false;
  }
  stats_.points_dropped += ev.points_dropped;
  stats_.times_clamped += ev.times_clamped;
  stats_.datagrams += ev.datagrams.size();
  ++stats_.ego_scans;
  out.push_back(std::move(ev));
  return true;
}

bool WireEventDecoder::feed(const WireEvent& event, DecodedFrame& frame) {
  const std::int64_t disciplined_ns = decoder_.epoch_ns() + event.time_ns;
  if (event.kind == WireEvent::Kind::kCan) {
    const firmware::DecodedCan decoded = decoder_.decode_can(event.can, disciplined_ns);
    if (decoded.kind == firmware::CanInputKind::kVehicle) localizer_.on_vehicle(decoded.vehicle);
    if (decoded.kind == firmware::CanInputKind::kGnssFix) localizer_.on_gnss(decoded.gnss);
    return false;
  }
  bool produced = false;
  for (const auto& d : event.datagrams) {
    if (!decoder_.on_datagram(d, event.time_ns)) continue;
    const firmware::DecodedCloud decoded = decoder_.decode_completed();
    if (decoded.kind == firmware::CloudKind::kMapCloud) localizer_.on_map_cloud(decoded.map);
    if (decoded.kind != firmware::CloudKind::kEgoScan) continue;
    const LocalizerFrameOutput& out = localizer_.on_ego_scan(decoded.ego);
    frame.frame = static_cast<int>(decoded.frame_index);
    frame.output = out;
    frame.pose = encoder_.encode(out, decoded.frame_index, decoded.gnss_used);
    frame.diagnostics = diagnostic_encoder_.encode(out, decoded.frame_index);
    produced = true;
  }
  return produced;
}

bool run_offline(const RecordingReader& reader, Localizer& localizer, firmware::InputDecoder& decoder,
                 const EventStreamConfig& config, const std::function<void(const DecodedFrame&)>& on_frame,
                 std::string& error) {
  EventStream stream;
  if (!stream.open(reader, config, error)) return false;
  decoder.set_epoch_ns(stream.epoch_ns());
  WireEventDecoder wire(decoder, localizer);
  std::vector<WireEvent> events;
  for (int i = 0; i < stream.frame_count(); ++i) {
    events.clear();
    if (!stream.next_frame(i, events, error)) return false;
    for (const WireEvent& ev : events) {
      DecodedFrame f;
      if (wire.feed(ev, f)) on_frame(f);
    }
  }
  return true;
}

}  // namespace v2xloc::sim::replay
