#include "tools/eval/offline_run.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#define V2XLOC_HAVE_CALLGRIND 1
#endif

#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/share_schedule.hpp"
#include "firmware/wire/wire_conventions.hpp"
#include "firmware/protocol/can_messages.hpp"
#include "firmware/trust/background_file.hpp"
#include "firmware/wire/background_store.hpp"
#include "host_sim/cloud_io/point_cloud.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/sim_trust.hpp"

namespace v2xloc::eval {
namespace {

Mat4d to_mat(const Eigen::Isometry3d& iso) { return iso.matrix(); }

// The recording's surveyed backgrounds (its trust list's `background` lines), read, checked and
// kept as the firmware keeps them (firmware/wire/background_store.hpp: size cap, the list's
// digest, the sender), so that the in-process run refuses the clouds the firmware refuses. A bad
// file fails the run, as it stops the firmware. The store lives here until the next run: the
// localizer reads it until its next configure().
std::unique_ptr<firmware::BackgroundStore> g_backgrounds;

bool provision_backgrounds(const sim::RecordingReader& reader, Localizer& localizer, std::size_t& loaded,
                           std::string& error) {
  g_backgrounds = std::make_unique<firmware::BackgroundStore>();  // after configure(): the old one is no longer read
  loaded = 0;
  const std::string list_path = reader.trust_list_path();
  if (list_path.empty()) return true;
  trust::TrustList list;
  if (!sim::load_trust_list(list_path, list, error)) return false;
  const std::filesystem::path dir = std::filesystem::path(list_path).parent_path();
  for (const trust::TrustedSigner& s : list.view()) {
    if (!s.has_background) continue;
    const std::string path = (dir / s.background_file.data()).string();
    if (g_backgrounds->full()) {
      error = path + ": more backgrounds than the firmware holds (" + std::to_string(firmware::BackgroundStore::kUnits) + ")";
      return false;
    }
    std::string bytes;
    if (!sim::read_text_file(path, trust::kMaxBackgroundFileBytes, bytes, error)) return false;
    const trust::BackgroundStatus status = g_backgrounds->load(
        s, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
    if (status != trust::BackgroundStatus::kOk) {
      error = path + ": " + trust::to_string(status);
      return false;
    }
  }
  loaded = g_backgrounds->provision(localizer);
  if (loaded != g_backgrounds->count()) {
    error = list_path + ": the localizer refused a surveyed background (not valid for it)";
    return false;
  }
  return true;
}

// Wall time of one localizer call [s].
template <class F>
double timed_seconds(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The localizer's stage probe on the host: wall time between marks per stage, and (under
// callgrind, when asked) one stats dump per finished stage so instructions split the same way.
class StageClock {
 public:
  using Clock = std::chrono::steady_clock;
  StageClock(bool timing, bool dumps) : timing_(timing), dumps_(dumps) {}
  static void on_mark(void* self, LocalizerStage s) { static_cast<StageClock*>(self)->mark(s); }
  StageProbe probe() { return StageProbe{&StageClock::on_mark, this}; }
  bool active() const { return timing_ || dumps_; }
  void mark(LocalizerStage s) {
    if (!active()) return;
    const auto now = Clock::now();
    if (current_ != LocalizerStage::kIdle) {
      ms_[static_cast<std::size_t>(current_)] += std::chrono::duration<double, std::milli>(now - last_).count();
    }
#ifdef V2XLOC_HAVE_CALLGRIND
    if (dumps_ && RUNNING_ON_VALGRIND) {
      char label[64];
      std::snprintf(label, sizeof label, "frame %d %s", frame_, stage_name(current_));
      CALLGRIND_DUMP_STATS_AT(label);
    }
#endif
    current_ = s;
    last_ = Clock::now();
  }
  void begin_period(int frame) {
    mark(LocalizerStage::kIdle);
    frame_ = frame;
    ms_.fill(0.0);
  }
  const StageMs& period_ms() const { return ms_; }

 private:
  bool timing_, dumps_;
  int frame_ = -1;
  LocalizerStage current_ = LocalizerStage::kIdle;
  Clock::time_point last_ = Clock::now();
  StageMs ms_{};
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) ;
  return v[std::min(v.size() - 1, k > 0 ? k - 1 : 0)];
}

// "infra_3" -> 1 + 3, "agent_1..." -> 32 + 1: stable ids per sensor. The number comes from the
// recording, so it is parsed without throwing and must keep infra and agent ids apart.
bool source_id_of(const sim::MapCloudInfo& info, std::uint32_t& id, std::string& error) {
  const auto digit = info.sensor.find_first_of("0123456789");
  std::uint32_t k = 0;
  if (digit != std::string::npos) {
    const char* first = info.sensor.data() + digit;
    const char* last = info.sensor.data() + info.sensor.size();
    const auto r = std::from_chars(first, last, k);
    if (r.ec != std::errc() || k >= firmware::kAgentSenderBase - firmware::kInfraSenderBase) {
      error = "map cloud sensor '" + info.sensor + "': index must be 0.." +
              std::to_string(firmware::kAgentSenderBase - firmware::kInfraSenderBase - 1);
      return false;
    }
  }
  id = info.kind == "agent" ? firmware::kAgentSenderBase + k : firmware::kInfraSenderBase + k;
  return true;
}

}  // namespace

void take_revisions(const TrajectoryBackfill& backfill, std::size_t newest, std::vector<FrameRecord>& records) {
  for (std::size_t age = 0; age < backfill.size() && age <= newest; ++age) {
    FrameRecord& earlier = records[newest - age];
    if (!backfill.pose(earlier.out.frame, earlier.lagged_pose, earlier.revised)) break;
  }
}

bool run_offline(const sim::RecordingReader& reader, Localizer& localizer, const RunOptions& options,
                 std::vector<FrameRecord>& records, RunStats& stats, std::string& error) {
  std::vector<sim::CanLogFrame> can;
  if (!reader.can_frames(can, error)) return false;
  const auto& clouds = reader.map_clouds();
  const GeodeticOrigin origin =
      make_geodetic_origin(reader.origin_lat_deg(), reader.origin_lon_deg(), reader.origin_alt_m());
  LocalizerParams params = options.params;
  params.shadow_ungated_filter = true;  // the evaluator reports the ungated "Fused" column
  localizer.configure(params, origin);
  stats = {};
  if (!provision_backgrounds(reader, localizer, stats.backgrounds_loaded, error)) return false;

  const int frames = options.max_frames < 0 ? reader.frame_count()
                                            : std::min(options.max_frames, reader.frame_count());
  records.assign(static_cast<std::size_t>(frames), FrameRecord{});
  std::size_t next_can = 0, next_cloud = 0;
  // CAN goes through the firmware's decoder (same DBC decoding, same fix assembly, same checks).
  auto decoder = std::make_unique<firmware::InputDecoder>(0);
  bool has_gnss = false;
  Eigen::Vector3d gnss_body = Eigen::Vector3d::Zero();
  // Map clouds waiting for their period (the firmware's verification schedule), by schedule slot.
  struct WaitingCloud {
    const sim::MapCloudInfo* info = nullptr;
    cloud_io::PointCloud cloud;
  };
  firmware::ShareSchedule schedule;
  std::vector<WaitingCloud> waiting(firmware::ShareSchedule::kCapacity);
  cloud_io::PointCloud scan;
  std::vector<Vec3f> scan_points;
  std::vector<float> scan_times;
  sim::Image16 disparity;
  using Clock = std::chrono::steady_clock;
  StageClock stages(options.timing, options.callgrind_dumps);
  localizer.set_stage_probe(stages.active() ? stages.probe() : StageProbe{});

  for (int i = 0; i < frames; ++i) {
    const double t = reader.frame_time(i);
    FrameRecord& rec = records[static_cast<std::size_t>(i)];
    rec.t = t;
    rec.truth = reader.ground_truth()[static_cast<std::size_t>(i)].pose;
    double frame_seconds = 0.0;
    stages.begin_period(i);
    stages.mark(LocalizerStage::kInputs);
    // 1. CAN frames up to t.
    for (; next_can < can.size() && can[next_can].t <= t + 1e-9; ++next_can) {
      const sim::CanLogFrame& f = can[next_can];
      hal::CanFrame frame;
      frame.id = f.id;
      frame.dlc = f.dlc;
      for (int b = 0; b < 8; ++b) frame.data[b] = f.data[b];
      const firmware::DecodedCan decoded = decoder->decode_can(frame, static_cast<std::int64_t>(std::llround(f.t * 1e9)));
      if (decoded.kind == firmware::CanInputKind::kRejected) ++stats.can_decode_errors;
      if (decoded.kind == firmware::CanInputKind::kVehicle) {
        frame_seconds += timed_seconds([&] { localizer.on_vehicle(decoded.vehicle); });
      }
      if (decoded.kind == firmware::CanInputKind::kGnssFix) {
        frame_seconds += timed_seconds([&] { localizer.on_gnss(decoded.gnss); });
        if (decoded.gnss.valid) {
          const GnssInput& fix = decoded.gnss;
          const Vec3d enu = geodetic_to_enu(origin, GeodeticPoint{fix.lat_deg, fix.lon_deg, fix.alt_m});
          gnss_body = enu - options.gnss_antenna_in_body;  // roll = pitch = 0: the lever is vertical
          has_gnss = true;
        }
      }
    }
    stages.mark(LocalizerStage::kIdle);
    rec.has_gnss = has_gnss;
    rec.gnss_body = gnss_body;
    // 2. Map clouds up to t, on the firmware's share schedule (firmware/wire/share_schedule.hpp):
    //    queued as they arrive, at most kMaxSignatureVerificationsPerPeriod reach the map per period.
    for (; next_cloud < clouds.size() && clouds[next_cloud].stamp <= t + 1e-9; ++next_cloud) {
      const firmware::ShareSchedule::Admission admission = schedule.admit();
      if (admission.dropped_oldest) ++stats.map_clouds_dropped;
      waiting[admission.slot].info = &clouds[next_cloud];
      if (!reader.load_map_cloud(clouds[next_cloud], waiting[admission.slot].cloud, error)) return false;
    }
    schedule.begin_period();
    std::size_t slot = 0;
    // A share the map would not fuse (paced) costs the firmware no signature check: refunded.
    const std::size_t shares = firmware::shares_this_period(localizer.map_clouds_per_period());
    std::size_t shares_fused = 0;
    for (std::size_t k = 0; k < firmware::kShareVerifyQueueCapacity && shares_fused < shares && schedule.release(slot); ++k) {
      const sim::MapCloudInfo& info = *waiting[slot].info;
      const cloud_io::PointCloud& cloud = waiting[slot].cloud;
      MapCloudInput in;
      if (!source_id_of(info, in.source_id, error)) return false;
      if (!localizer.wants_map_cloud(in.source_id, info.stamp)) {
        schedule.refund();
        ++stats.map_clouds_paced;
        continue;
      }
      in.is_agent = info.kind == "agent";
      in.t = info.stamp;
      in.world_T_sensor = to_mat(info.sensor_pose);
      in.points = std::span<const Vec3f>(cloud.points.data(), cloud.points.size());
      ++shares_fused;
      stages.mark(LocalizerStage::kMapInsert);
      const auto t0 = Clock::now();
      const MapInsertResult r = localizer.on_map_cloud(in);
      frame_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
      stages.mark(LocalizerStage::kIdle);
      ++stats.map_clouds;
      if (r.status == MapInsertStatus::kRejectedInconsistent || r.status == MapInsertStatus::kBackgroundMismatch)
        ++stats.map_clouds_rejected;
    }
    // 3. The ego scan.
    if (!reader.ego_scan(i, scan, error)) return false;
    EgoScanInput in;
    in.t = t;
    in.points = std::span<const Vec3f>(scan.points.data(), scan.points.size());
    if (scan.time.size() == scan.points.size()) {
      in.point_times = std::span<const float>(scan.time.data(), scan.time.size());
    }
    in.body_T_lidar = reader.ego_lidar_mount().matrix();
    if (options.params.use_stereo && reader.has_stereo()) {
      if (!reader.disparity(i, disparity, error)) return false;
      const sim::StereoCalibrationInfo& cal = reader.stereo_calibration();
      in.stereo.disparity = std::span<const std::uint16_t>(disparity.pixels.data(), disparity.pixels.size());
      in.stereo.width = static_cast<std::uint32_t>(disparity.width);
      in.stereo.height = static_cast<std::uint32_t>(disparity.height);
      in.stereo.calibration.fx = cal.fx;
      in.stereo.calibration.fy = cal.fy;
      in.stereo.calibration.cx = cal.cx;
      in.stereo.calibration.cy = cal.cy;
      in.stereo.calibration.baseline = cal.baseline;
      in.stereo.calibration.vehicle_T_camera = cal.camera_to_body.matrix();
      in.stereo.disparity_sigma = cal.disparity_sigma_px;
    }
    const auto t0 = Clock::now();
    rec.out = localizer.on_ego_scan(in);
    rec.lagged_pose = rec.out.fused_pose.matrix();
    frame_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    stats.seconds += frame_seconds;
    stats.max_frame_ms = std::max(stats.max_frame_ms, frame_seconds * 1e3);
    stages.mark(LocalizerStage::kIdle);  // on_ego_scan ends idle; here for inputs-only periods
    if (options.timing) stats.period_stage_ms.push_back(stages.period_ms());
    take_revisions(localizer.backfill(), static_cast<std::size_t>(i), records);
    if (rec.out.gate_decided && rec.out.gate_decided_frame < records.size()) {
      records[rec.out.gate_decided_frame].gate_decided = true;
      records[rec.out.gate_decided_frame].gate_valid = rec.out.gate_decided_valid;
    }
    if (!options.quiet) {
      const Eigen::Vector3d fused = rec.out.fused_pose.translation();
      std::fprintf(stderr,
                   "\r  frame %4d/%d  mode %d  fit %.3f rmse %.3f  err fused %.3f m  %.0f ms   ",
                   i + 1, frames, static_cast<int>(rec.out.mode), rec.out.fitness,
                   rec.out.inlier_rmse, (fused - rec.truth.translation()).norm(),
                   frame_seconds * 1e3);
    }
  }
  localizer.set_stage_probe(StageProbe{});
  stats.counters = localizer.counters();
  stats.map_background_checked = localizer.map().counters().background_checked;
  stats.map_background_mismatch = localizer.map().counters().background_mismatch;
  if (!options.quiet) {
    const LocalizerCounters& c = stats.counters;
    std::fprintf(stderr,
                 "\n  global searches %u (accepted %u), tracking %u, registrations ok %u, fused %u, "
                 "filter resets %u, confirmed %u, inconsistent %u, unconstrained %u, final ICP paused %u, track losses %u, audits %u, basin switches %u, ambiguities resolved %u, stereo %u (fused %u), map rebuilds %u, map normals %u (refused %u); EKF: registrations fused %llu rejected %llu, GNSS fused %llu "
                 "rejected %llu, too late %llu, invalid %llu, numeric %llu, history overflows %llu\n",
                 c.global_searches, c.global_accepted, c.tracking_registrations, c.registrations_ok,
                 c.registrations_fused, c.filter_resets, c.global_confirmed, c.global_inconsistent, c.global_unconstrained,
                 c.global_final_icp_paused,
                 c.track_losses,
                 c.basin_audits, c.basin_switches, c.ambiguities_resolved, c.stereo_registrations, c.stereo_fused,
                 c.map_rebuilds, c.map_normals_computed, c.map_normals_refused,
                 static_cast<unsigned long long>(localizer.ekf().counters().registration_fused),
                 static_cast<unsigned long long>(localizer.ekf().counters().registration_rejected),
                 static_cast<unsigned long long>(localizer.ekf().counters().gnss_fused),
                 static_cast<unsigned long long>(localizer.ekf().counters().gnss_rejected),
                 static_cast<unsigned long long>(localizer.ekf().counters().too_late),
                 static_cast<unsigned long long>(localizer.ekf().counters().invalid_inputs),
                 static_cast<unsigned long long>(localizer.ekf().counters().numeric_failures),
                 static_cast<unsigned long long>(localizer.ekf().counters().history_overflows));
  }
  return true;
}

}  // namespace v2xloc::eval

namespace v2xloc::eval {

TimingSummary summarize_timing(const std::vector<StageMs>& periods) {
  TimingSummary out;
  if (periods.empty()) return out;
  std::vector<double> totals;
  for (std::size_t i = 0; i < periods.size(); ++i) {
    double sum = 0.0;
    for (double v : periods[i]) sum += v;
    totals.push_back(sum);
    if (out.worst_frame < 0 || sum > out.max_ms) {
      out.max_ms = sum;
      out.worst_frame = static_cast<int>(i);
    }
  }
  out.median_ms = percentile(totals, 0.5);
  out.p99_ms = percentile(totals, 0.99);
  out.worst_stages_ms = periods[static_cast<std::size_t>(out.worst_frame)];
  for (std::size_t s = 0; s < out.median_stages_ms.size(); ++s) {
    std::vector<double> v;
    for (const StageMs& p : periods) v.push_back(p[s]);
    out.median_stages_ms[s] = percentile(v, 0.5);
  }
  return out;
}

}  // namespace v2xloc::eval
