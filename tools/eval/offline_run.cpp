#include "tools/eval/offline_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "firmware/trust/background_file.hpp"
#include "firmware/wire/background_store.hpp"
#include "firmware/wire/input_decoder.hpp"
#include "firmware/wire/period_driver.hpp"
#include "host_sim/common/text_file.hpp"
#include "host_sim/recording/sim_trust.hpp"
#include "host_sim/replay/event_stream.hpp"
#include "tools/eval/gnss_track.hpp"
#include "tools/eval/in_process_port.hpp"
#include "tools/eval/stage_clock.hpp"

namespace v2xloc::eval {
namespace {

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

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) ;
  return v[std::min(v.size() - 1, k > 0 ? k - 1 : 0)];
}

// A share older than this behind the newest one is refused by the verifier (too old, 1 s) before
// it can reach the map: its recorded cloud is no longer kept.
constexpr std::int64_t kShareKeepNs = 3'000'000'000;

// Frame i's stereo disparity as the localizer reads it (none unless asked and recorded).
bool stereo_of(const sim::RecordingReader& reader, const RunOptions& options, int i, sim::Image16& disparity,
               StereoInput& out, std::string& error) {
  out = StereoInput{};
  if (!options.params.use_stereo || !reader.has_stereo()) return true;
  if (!reader.disparity(i, disparity, error)) return false;
  const sim::StereoCalibrationInfo& cal = reader.stereo_calibration();
  out.disparity = std::span<const std::uint16_t>(disparity.pixels.data(), disparity.pixels.size());
  out.width = static_cast<std::uint32_t>(disparity.width);
  out.height = static_cast<std::uint32_t>(disparity.height);
  out.calibration.fx = cal.fx;
  out.calibration.fy = cal.fy;
  out.calibration.cx = cal.cx;
  out.calibration.cy = cal.cy;
  out.calibration.baseline = cal.baseline;
  out.calibration.vehicle_T_camera = cal.camera_to_body.matrix();
  out.disparity_sigma = cal.disparity_sigma_px;
  return true;
}

void print_progress(const FrameRecord& rec, int i, int frames, double frame_seconds) {
  const Eigen::Vector3d fused = rec.out.fused_pose.translation();
  std::fprintf(stderr, "\r  frame %4d/%d  mode %d  fit %.3f rmse %.3f  err fused %.3f m  %.0f ms   ", i + 1, frames,
               static_cast<int>(rec.out.mode), rec.out.fitness, rec.out.inlier_rmse,
               (fused - rec.truth.translation()).norm(), frame_seconds * 1e3);
}

// Frame i's wire events through the firmware's decoder and period driver, the port holding the
// recorded clouds (shares kept, the scan with its stereo); the ego scan must close period i.
bool feed_frame(const sim::RecordingReader& reader, const RunOptions& options, int i,
                std::vector<sim::replay::WireEvent>& events, InProcessPort& port, sim::replay::WireEventDecoder& wire,
                sim::Image16& disparity, FrameRecord& rec, std::string& error) {
  bool closed = false;
  for (sim::replay::WireEvent& ev : events) {
    if (ev.kind == sim::replay::WireEvent::Kind::kMapCloud) {
      port.keep_share(ev.sender_id, ev.time_ns, std::move(ev.source), ev.time_ns - kShareKeepNs);
    } else if (ev.kind == sim::replay::WireEvent::Kind::kEgoScan) {
      StereoInput stereo;
      if (!stereo_of(reader, options, i, disparity, stereo, error)) return false;
      port.set_scan(std::move(ev.source), stereo);
    }
    std::string period_error;
    wire.feed(ev, [&](const sim::replay::DecodedFrame& decoded) {
      if (decoded.frame != i || decoded.without_scan) {
        period_error = "in-process run: frame " + std::to_string(i) + " closed period " + std::to_string(decoded.frame) +
                       (decoded.without_scan ? " without a scan (a missing scan: run it through --firmware)" : "");
        return;
      }
      rec.out = decoded.output;
      closed = true;
    });
    if (!period_error.empty()) {
      error = period_error;
      return false;
    }
    if (!port.error().empty()) {
      error = port.error();
      return false;
    }
  }
  if (!closed) {
    error = "in-process run: the ego scan of frame " + std::to_string(i) + " did not close a period";
    return false;
  }
  return true;
}

// After period i: its time, the backfill's revisions of earlier frames, the gate's decision on
// the frame it names.
void close_frame(const Localizer& localizer, const RunOptions& options, InProcessPort& port, StageClock& stages, int i,
                 int frames, std::vector<FrameRecord>& records, RunStats& stats) {
  FrameRecord& rec = records[static_cast<std::size_t>(i)];
  rec.lagged_pose = rec.out.fused_pose.matrix();
  const double frame_seconds = port.take_seconds();
  stats.seconds += frame_seconds;
  stats.max_frame_ms = std::max(stats.max_frame_ms, frame_seconds * 1e3);
  stages.mark(LocalizerStage::kIdle);
  if (options.timing) stats.period_stage_ms.push_back(stages.period_ms());
  take_revisions(localizer.backfill(), static_cast<std::size_t>(i), records);
  if (rec.out.gate_decided && rec.out.gate_decided_frame < records.size()) {
    records[rec.out.gate_decided_frame].gate_decided = true;
    records[rec.out.gate_decided_frame].gate_valid = rec.out.gate_decided_valid;
  }
  if (!options.quiet) print_progress(rec, i, frames, frame_seconds);
}

// The decoder's, period driver's, verifier's and localizer's counters of the run.
void collect_counters(const firmware::InputDecoder& decoder, const sim::replay::WireEventDecoder& wire,
                      const Localizer& localizer, RunStats& stats) {
  const firmware::CanCounters& can = decoder.can().counters();
  const firmware::ShareCounters& s = decoder.shares().counters();
  const firmware::PeriodCounters& p = wire.driver().counters();
  stats.can_decode_errors = can.can_rejected + can.can_repeated;
  stats.map_clouds = p.map_handed;
  stats.map_clouds_rejected = p.map_inconsistent + p.map_background_mismatch;
  stats.map_clouds_paced = s.shares_paced + s.shares_paced_on_arrival;
  stats.map_clouds_dropped = s.shares_queue_dropped;
  stats.map_shares_untrusted = s.shares_untrusted + s.shares_off_background;
  stats.trust = decoder.shares().verifier().counters();
  stats.counters = localizer.counters();
  stats.map_background_checked = localizer.map().counters().background_checked;
  stats.map_background_mismatch = localizer.map().counters().background_mismatch;
}

void print_counters(const RunStats& stats, const Localizer& localizer) {
  const LocalizerCounters& c = stats.counters;
  std::fprintf(stderr, "\n  shares: %zu to the map (%zu refused by it), %zu refused by the trust checks"
               " (pose_mismatch %llu, missing_signature %llu, bad_signature %llu, too_old %llu, replay %llu)\n",
               stats.map_clouds, stats.map_clouds_rejected, stats.map_shares_untrusted,
               static_cast<unsigned long long>(stats.trust.pose_mismatch),
               static_cast<unsigned long long>(stats.trust.missing_signature),
               static_cast<unsigned long long>(stats.trust.bad_signature),
               static_cast<unsigned long long>(stats.trust.too_old),
               static_cast<unsigned long long>(stats.trust.replay));
  std::fprintf(stderr,
               "  global searches %u (accepted %u), tracking %u, registrations ok %u, fused %u, "
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

}  // namespace

void take_revisions(const TrajectoryBackfill& backfill, std::size_t newest, std::vector<FrameRecord>& records) {
  for (std::size_t age = 0; age < backfill.size() && age <= newest; ++age) {
    FrameRecord& earlier = records[newest - age];
    if (!backfill.pose(earlier.out.frame, earlier.lagged_pose, earlier.revised)) break;
  }
}

bool run_offline(const sim::RecordingReader& reader, Localizer& localizer, const RunOptions& options,
                 std::vector<FrameRecord>& records, RunStats& stats, std::string& error) {
  const GeodeticOrigin origin =
      make_geodetic_origin(reader.origin_lat_deg(), reader.origin_lon_deg(), reader.origin_alt_m());
  LocalizerParams params = options.params;
  params.filter.shadow_ungated_filter = true;  // the evaluator reports the ungated "Fused" column
  localizer.configure(params, origin);
  stats = {};
  if (!provision_backgrounds(reader, localizer, stats.backgrounds_loaded, error)) return false;

  // The recording as the firmware receives it (signed shares, the CAN log), decided on by the
  // firmware's decoder and period driver; the port feeds the localizer the recorded clouds.
  sim::replay::EventStreamConfig config;
  config.max_frames = options.max_frames;
  config.keep_source_clouds = true;
  sim::replay::EventStream stream;
  if (!stream.open(reader, config, error)) return false;
  auto decoder = std::make_unique<firmware::InputDecoder>(stream.epoch_ns());
  decoder->provision_trust(stream.trust_list());
  StageClock stages(options.timing, options.callgrind_dumps);
  localizer.set_stage_probe(stages.active() ? stages.probe() : StageProbe{});
  InProcessPort port(localizer, stages);
  sim::replay::WireEventDecoder wire(*decoder, port);

  const int frames = stream.frame_count();
  records.assign(static_cast<std::size_t>(frames), FrameRecord{});
  std::vector<sim::replay::WireEvent> events;
  sim::Image16 disparity;
  for (int i = 0; i < frames; ++i) {
    FrameRecord& rec = records[static_cast<std::size_t>(i)];
    rec.t = reader.frame_time(i);
    rec.truth = reader.ground_truth()[static_cast<std::size_t>(i)].pose;
    events.clear();
    if (!stream.next_frame(i, events, error)) return false;
    stages.begin_period(i);
    if (!feed_frame(reader, options, i, events, port, wire, disparity, rec, error)) return false;
    close_frame(localizer, options, port, stages, i, frames, records, stats);
  }
  if (!fill_gnss(reader, options.gnss_antenna_in_body, records, error)) return false;
  localizer.set_stage_probe(StageProbe{});
  collect_counters(*decoder, wire, localizer, stats);
  if (!options.quiet) print_counters(stats, localizer);
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
