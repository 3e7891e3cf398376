#include "host_sim/replay/event_stream.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <span>

#include "host_sim/canlog/candump_log.hpp"
#include "firmware/trust/cloud_digest.hpp"
#include "host_sim/replay/openssl_sha256.hpp"

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

}  // namespace

bool EventStream::sender_id_for(const MapCloudInfo& info, std::uint32_t& sender_id) {
  return sim_sender_id(info.kind, info.sensor, sender_id);
}

bool EventStream::open(const RecordingReader& reader, const EventStreamConfig& config, std::string& error) {
  *this = EventStream{};
  reader_ = &reader;
  config_ = config;
  frame_count_ = reader.frame_count();
  if (config.max_frames >= 0) frame_count_ = std::min(frame_count_, config.max_frames);
  // Whole microseconds, so candump stamps (us) map to exact recording nanoseconds.
  epoch_ns_ = std::llround(reader.time_origin_unix() * 1e6) * 1000;
  if (!reader.can_log_path().empty()) {
    std::vector<CandumpRecord> records;  // in the current CAN layout, whichever the recording has
    if (!reader.can_records(records, error)) return false;
    can_.reserve(records.size());
    for (const CandumpRecord& r : records) can_.push_back({r.timestamp_us * 1000 - epoch_ns_, r.frame});
  }
  for (const MapCloudInfo& c : reader.map_clouds()) {
    std::uint32_t id = 0;
    if (!sender_id_for(c, id)) {
      error = "map cloud with unknown sensor name: " + c.sensor + " (" + c.kind + ")";
      return false;
    }
  }
  if (config.imu && !reader.imu_reports_path().empty()) {
    if (!reader.imu_reports(imu_, error)) return false;
    apply_imu_faults(config.faults.imu, config.faults.seed, imu_, stats_.faults.imu);
  }
  signers_ = recording_signers(reader);
  if (!recording_trust_list(reader, signers_, trust_list_, error)) return false;
  faults_.configure(config.faults);
  sign_shares_ = config.sign_map_shares;
  return true;
}

std::int64_t EventStream::frame_time_ns(int i) const { return seconds_to_ns(reader_->frame_time(i)); }

bool EventStream::fragment(protocol::CloudMessageType type, std::uint32_t sender_id, std::uint32_t seq,
                           std::int64_t stamp_ns, const Eigen::Isometry3d& pose, const cloud_io::PointCloud& cloud,
                           bool with_times, WireEvent& ev, std::string& error) const {
  // The points are already packed x y z floats: the fragmenter reads them in place.
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
  const std::span<const float> xyz(reinterpret_cast<const float*>(cloud.points.data()), 3 * cloud.points.size());
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

bool EventStream::map_share(std::uint32_t sender_id, std::uint32_t seq, std::int64_t stamp_ns, const Eigen::Isometry3d& pose,
                            const cloud_io::PointCloud& cloud, const SimSigner* signer, WireEvent& ev,
                            std::string& error) const {
  ev.kind = WireEvent::Kind::kMapCloud;
  ev.time_ns = stamp_ns;
  if (!fragment(protocol::CloudMessageType::kMapShare, sender_id, seq, stamp_ns, pose, cloud, false, ev, error)) return false;
  if (signer == nullptr || !sign_shares_) return true;
  // Sign what the receiver will hash: the payload bytes of our own fragments, per fragment.
  std::vector<trust::ShareDigestBuilder::Entry> scratch(ev.datagrams.size());
  trust::ShareDigestBuilder builder(scratch, openssl_sha256);
  for (const auto& d : ev.datagrams) {
    if (!builder.add(d)) {
      error = "map share fragment did not parse for signing";
      return false;
    }
  }
  protocol::ReassembledCloud frame;
  trust::Digest digest{};
  if (!builder.finish(frame, digest)) {
    error = "map share incomplete for signing";
    return false;
  }
  protocol::CloudSignature sig;
  if (trust::sign_cloud(signer->priv, signer->pub, frame, digest, static_cast<std::uint64_t>(epoch_ns_ + stamp_ns), sig) !=
      trust::CryptoStatus::kOk) {
    error = "signing failed";
    return false;
  }
  std::vector<std::uint8_t> d(protocol::signature_wire::kBytes);
  protocol::encode_signature_datagram(sig, d);
  ev.datagrams.insert(ev.datagrams.begin(), std::move(d));  // the signature precedes the fragments
  return true;
}

bool EventStream::next_frame(int i, std::vector<WireEvent>& out, std::string& error) {
  if (i != next_frame_ || i >= frame_count_) {
    error = "frames must be requested in order (expected " + std::to_string(next_frame_) + ", got " + std::to_string(i) + ")";
    return false;
  }
  ++next_frame_;
  const std::int64_t t_i = frame_time_ns(i);
  append_can(t_i, out);
  append_imu(t_i, out);
  if (!send_map_clouds(t_i, error)) return false;
  deliver_due_shares(t_i, out);
  return append_ego_scan(i, t_i, out, error);
}

void EventStream::append_can(std::int64_t t_i, std::vector<WireEvent>& out) {
  for (; next_can_ < can_.size() && can_[next_can_].time_ns <= t_i; ++next_can_) {
    const TimedCan& c = can_[next_can_];
    if (faults_.gnss_dropped(c.frame.id, static_cast<double>(c.time_ns) * 1e-9)) {
      ++stats_.faults.gnss_frames_dropped;
      continue;
    }
    WireEvent ev;
    ev.kind = WireEvent::Kind::kCan;
    ev.time_ns = c.time_ns;
    ev.can = c.frame;
    out.push_back(ev);
    ++stats_.can_frames;
    append_can_burst(ev, out);
  }
}

void EventStream::append_imu(std::int64_t t_i, std::vector<WireEvent>& out) {
  for (; next_imu_ < imu_.size() && imu_[next_imu_].timestamp_ns <= t_i; ++next_imu_) {
    WireEvent ev;
    ev.kind = WireEvent::Kind::kImuReport;
    ev.time_ns = imu_[next_imu_].timestamp_ns;
    ev.imu = imu_[next_imu_];
    out.push_back(std::move(ev));
    ++stats_.imu_reports;
  }
}

// The CAN burst fault, once, right after the first frame at or after its time: corrupt copies of
// that frame (bit flips: CRC; verbatim repeats: rolling counter; wrong DLC).
void EventStream::append_can_burst(const WireEvent& after, std::vector<WireEvent>& out) {
  const FaultSpec& fs = faults_.spec();
  if (fs.can_burst <= 0 || burst_done_ || after.time_ns < seconds_to_ns(fs.can_burst_at_s)) return;
  burst_done_ = true;
  for (int k = 0; k < fs.can_burst; ++k) {
    WireEvent bad = after;
    const int kind = faults_.rng().uniform_int(0, 2);
    if (kind == 0) {
      bad.can.data[faults_.rng().uniform_int(0, 7)] ^= static_cast<std::uint8_t>(1u << faults_.rng().uniform_int(0, 7));
    } else if (kind == 2) {
      bad.can.dlc = static_cast<std::uint8_t>(faults_.rng().uniform_int(0, 7));
    }
    out.push_back(bad);
    ++stats_.faults.can_corrupt_sent;
  }
}

// Every map cloud stamped up to t_i becomes its shares (transport faults applied), held until
// their (possibly delayed) arrival time.
bool EventStream::send_map_clouds(std::int64_t t_i, std::string& error) {
  const auto& clouds = reader_->map_clouds();
  for (; next_cloud_ < clouds.size() && seconds_to_ns(clouds[next_cloud_].stamp) <= t_i; ++next_cloud_) {
    const MapCloudInfo& info = clouds[next_cloud_];
    if (info.kind == "infra" && faults_.infra_dropped(info.stamp)) {
      ++stats_.faults.infra_shares_dropped;
      continue;
    }
    std::vector<WireEvent> shares;
    if (!share_events(info, shares, error)) return false;
    for (WireEvent& e : shares) {
      faults_.transport(e.datagrams, stats_.faults);
      if (faults_.spec().delay_s > 0) {
        e.time_ns += seconds_to_ns(faults_.spec().delay_s);
        ++stats_.faults.shares_delayed;
      }
      delayed_.push_back(std::move(e));
    }
  }
  return true;
}

// One recorded map cloud as the shares sent for it: its source's own (shifted, when the source is
// a signed rogue), then the copies a rogue fault adds.
bool EventStream::share_events(const MapCloudInfo& info, std::vector<WireEvent>& shares, std::string& error) {
  ShareSource source;
  source.info = &info;
  sender_id_for(info, source.id);
  if (!reader_->load_map_cloud(info, source.cloud, error)) return false;
  if (cloud_seq_.size() <= source.id) cloud_seq_.resize(source.id + 1, 0);
  source.signer = signer_for(info);
  source.stamp_ns = seconds_to_ns(info.stamp);
  source.seq = cloud_seq_[source.id]++;
  const RogueShare rogue = rogue_share(info, source.cloud);
  const cloud_io::PointCloud& rogue_cloud = rogue.moved.points.empty() ? source.cloud : rogue.moved;
  const FaultSpec& fs = faults_.spec();
  const bool insider = rogue.active && fs.rogue_signed && fs.rogue_shift_m != 0;
  shares.emplace_back();
  if (!map_share(source.id, source.seq, source.stamp_ns, insider ? rogue.pose : info.sensor_pose,
                 insider ? rogue_cloud : source.cloud, source.signer, shares.back(), error)) {
    return false;
  }
  if (insider) ++stats_.faults.rogue_shares;
  if (!append_rogue_copies(source, rogue, rogue_cloud, shares, error)) return false;
  stats_.points_dropped += shares.front().points_dropped;
  ++stats_.map_clouds;
  if (config_.keep_source_clouds) shares.front().source = std::move(source.cloud);
  return true;
}

const SimSigner* EventStream::signer_for(const MapCloudInfo& info) const {
  const SimSigner* signer = nullptr;
  if (!config_.sign_map_shares) return signer;
  for (const SimSigner& sg : signers_) {
    if (sg.sensor == info.sensor) signer = &sg;
  }
  return signer;
}

// The rogue fault on one map cloud: active for the rogue source; its pose shifted by rogue_shift_m
// in the world, or (rogue_points) the true pose with the points moved by the same world shift.
EventStream::RogueShare EventStream::rogue_share(const MapCloudInfo& info, const cloud_io::PointCloud& cloud) const {
  const FaultSpec& fs = faults_.spec();
  RogueShare r;
  r.active = (fs.rogue_shift_m != 0 || fs.rogue_future_s > 0) &&
             (fs.rogue_source == info.sensor || (fs.rogue_source == "all-infra" && info.kind == "infra"));
  r.pose = Eigen::Translation3d(fs.rogue_shift_m, 0, 0) * info.sensor_pose;
  if (r.active && fs.rogue_points && fs.rogue_shift_m != 0) {
    r.moved = cloud;
    const Eigen::Vector3f in_sensor =
        (info.sensor_pose.linear().transpose() * Eigen::Vector3d(fs.rogue_shift_m, 0, 0)).cast<float>();
    for (Eigen::Vector3f& p : r.moved.points) p += in_sensor;
    r.pose = info.sensor_pose;
  }
  return r;
}

// The extra shares a rogue fault sends besides the source's own: an unsigned shifted copy (an
// outsider), a copy dated in the future, and shares under sender ids nobody provisioned.
bool EventStream::append_rogue_copies(const ShareSource& source, const RogueShare& rogue,
                                      const cloud_io::PointCloud& rogue_cloud, std::vector<WireEvent>& shares,
                                      std::string& error) {
  const FaultSpec& fs = faults_.spec();
  const MapCloudInfo& info = *source.info;
  const auto add = [&](std::uint32_t id, std::uint32_t seq, std::int64_t stamp_ns, const Eigen::Isometry3d& pose,
                       const cloud_io::PointCloud& cloud, const SimSigner* signer) {
    WireEvent r;
    if (!map_share(id, seq, stamp_ns, pose, cloud, signer, r, error)) return false;
    r.time_ns = source.stamp_ns;  // sent now, whatever it is dated
    shares.push_back(std::move(r));
    ++stats_.faults.rogue_shares;
    return true;
  };
  if (rogue.active && !fs.rogue_signed && fs.rogue_shift_m != 0 &&
      !add(source.id, source.seq + 0x40000000u, source.stamp_ns, rogue.pose, rogue_cloud, nullptr)) {
    return false;
  }
  if (rogue.active && fs.rogue_future_s > 0 &&
      !add(source.id, source.seq + 0x50000000u, source.stamp_ns + seconds_to_ns(fs.rogue_future_s), info.sensor_pose,
           source.cloud, fs.rogue_signed ? source.signer : nullptr)) {
    return false;
  }
  if (fs.rogue_ids > 0 && info.sensor == reader_->map_clouds().front().sensor) {  // once per share period
    for (int k = 0; k < fs.rogue_ids; ++k) {
      const std::uint32_t fake = 64u + static_cast<std::uint32_t>(k);
      if (!add(fake, source.seq, source.stamp_ns, info.sensor_pose, source.cloud, nullptr)) return false;
    }
  }
  return true;
}

// Every held share whose (possibly delayed) arrival time has come, in arrival order.
void EventStream::deliver_due_shares(std::int64_t t_i, std::vector<WireEvent>& out) {
  std::stable_sort(delayed_.begin(), delayed_.end(),
                   [](const WireEvent& a, const WireEvent& b) { return a.time_ns < b.time_ns; });
  std::size_t n_due = 0;
  while (n_due < delayed_.size() && delayed_[n_due].time_ns <= t_i) ++n_due;
  for (std::size_t k = 0; k < n_due; ++k) {
    stats_.datagrams += delayed_[k].datagrams.size();
    out.push_back(std::move(delayed_[k]));
  }
  delayed_.erase(delayed_.begin(), delayed_.begin() + static_cast<std::ptrdiff_t>(n_due));
}

bool EventStream::append_ego_scan(int i, std::int64_t t_i, std::vector<WireEvent>& out, std::string& error) {
  cloud_io::PointCloud scan;
  const bool blinded = faults_.lidar_blinded(static_cast<double>(t_i) * 1e-9);
  if (blinded) {
    ++stats_.faults.ego_scans_blinded;
    if (!faults_.spec().lidar_blind_empty) return true;  // a silent LiDAR: no scan, no period
  } else if (!reader_->ego_scan(i, scan, error)) {
    return false;
  }
  WireEvent ev;
  ev.kind = WireEvent::Kind::kEgoScan;
  ev.time_ns = t_i;
  ev.frame = i;
  std::int64_t ego_stamp = t_i;
  if (i == faults_.spec().ego_time_jump_frame) {  // one scan dated 1e18 ns (Unix), far in the future
    ego_stamp = 1'000'000'000'000'000'000LL - epoch_ns_;
    ++stats_.faults.ego_time_jumps;
  }
  if (!fragment(protocol::CloudMessageType::kEgoScan, firmware::kEgoSenderId, static_cast<std::uint32_t>(i), ego_stamp,
                reader_->ego_lidar_mount(), scan, config_.ego_point_times, ev, error)) {
    return false;
  }
  if (config_.keep_source_clouds) ev.source = std::move(scan);
  stats_.points_dropped += ev.points_dropped;
  stats_.times_clamped += ev.times_clamped;
  stats_.datagrams += ev.datagrams.size();
  ++stats_.ego_scans;
  out.push_back(std::move(ev));
  return true;
}

int WireEventDecoder::feed(const WireEvent& event, const std::function<void(const DecodedFrame&)>& on_frame) {
  int produced = 0;
  const auto publish = [&](const firmware::PeriodOutput& period) {
    DecodedFrame frame;
    frame.frame = static_cast<int>(period.frame_index);
    frame.without_scan = period.without_scan;
    frame.output = *period.output;
    frame.pose = period.pose;
    frame.diagnostics = period.diagnostics;
    ++produced;
    on_frame(frame);
  };
  if (event.kind == WireEvent::Kind::kCan) {
    driver_.on_can(event.can, decoder_.epoch_ns() + event.time_ns);
    driver_.close_overdue_periods(publish);
    return produced;
  }
  if (event.kind == WireEvent::Kind::kImuReport) {
    driver_.on_imu_report(std::span<const std::uint8_t>(event.imu.bytes.data(), event.imu.size),
                          decoder_.epoch_ns() + event.time_ns);
    return produced;
  }
  for (const auto& d : event.datagrams) {
    if (!decoder_.on_datagram(d, event.time_ns)) continue;
    const firmware::DecodedCloud decoded = driver_.take_completed();
    if (firmware::PeriodDriver::closes_period(decoded)) driver_.close_period(decoded, publish);
  }
  return produced;
}

bool run_offline(const RecordingReader& reader, Localizer& localizer, firmware::InputDecoder& decoder,
                 const EventStreamConfig& config, const std::function<void(const DecodedFrame&)>& on_frame,
                 std::string& error, LocalizerInputTap* tap) {
  EventStream stream;
  if (!stream.open(reader, config, error)) return false;
  decoder.set_epoch_ns(stream.epoch_ns());
  decoder.provision_trust(stream.trust_list());
  firmware::LocalizerAdapter<Localizer> port(localizer);
  WireEventDecoder wire(decoder, port);
  wire.set_tap(tap);
  std::vector<WireEvent> events;
  for (int i = 0; i < stream.frame_count(); ++i) {
    events.clear();
    if (!stream.next_frame(i, events, error)) return false;
    for (const WireEvent& ev : events) wire.feed(ev, on_frame);
  }
  return true;
}

}  // namespace v2xloc::sim::replay
