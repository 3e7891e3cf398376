#include "tools/eval/report.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>

#include "tools/eval/paper_table.hpp"

namespace v2xloc::eval {
namespace {

std::string cell(double ours, double paper) {
  char buf[64];
  if (ours < 0.0) {
    std::snprintf(buf, sizeof buf, "%8s (%6.3f)", "n/a", paper);
  } else {
    std::snprintf(buf, sizeof buf, "%8.3f (%6.3f)", ours, paper);
  }
  return buf;
}

using Json = nlohmann::json;

// Rounded to `decimals` as the report always printed them; a negative value (n/a) is null.
Json number(double v, int decimals = 4) {
  if (v < 0.0 || !std::isfinite(v)) return nullptr;
  const double scale = std::pow(10.0, decimals);
  return std::round(v * scale) / scale;
}

Json columns_json(const ColumnErrors& c) {
  return {{"slam", number(c.slam)},
          {"gps", number(c.gps)},
          {"reg", number(c.reg)},
          {"reg_valid", number(c.reg_valid)},
          {"fused", number(c.fused)},
          {"fused_valid", number(c.fused_valid)},
          {"fused_ungated", number(c.fused_ungated)},
          {"fused_lag", number(c.fused_lag)},
          {"gps_3d", number(c.gps_3d)}};
}

Json stages_json(const StageMs& ms) {
  Json out = Json::object();
  for (std::size_t s = 1; s < ms.size(); ++s)  // kIdle is never charged
    out[stage_name(static_cast<LocalizerStage>(s))] = number(ms[s], 3);
  return out;
}

std::string stages_text(const StageMs& ms) {
  std::string out;
  for (std::size_t s = 1; s < ms.size(); ++s) {
    if (ms[s] < 0.05) continue;
    char buf[96];
    std::snprintf(buf, sizeof buf, " %s %.1f", stage_name(static_cast<LocalizerStage>(s)), ms[s]);
    out += buf;
  }
  return out;
}

// Per row: relative error over 1 s (fused, odometry, GNSS) and the map-to-truth offset the valid
// registrations imply (on real data: the cooperative calibration's error).
std::string drift_and_offset_text(const std::vector<RowReport>& rows) {
  std::string out = "RPE 1 s (fused / odometry / GNSS) and the offset valid registrations imply (x y z, spread; yaw):\n";
  char buf[320];
  for (const RowReport& r : rows) {
    const RelativeErrors& e = r.metrics.rpe_1s;
    const OffsetEstimate& o = r.metrics.offset;
    std::snprintf(buf, sizeof buf, "  %-4d %-16s RPE %6.3f / %6.3f / %6.3f m   offset (%6.3f %6.3f %6.3f) m spread %.3f m",
                  r.sim, r.permutation.c_str(), e.fused, e.slam, e.gps, o.mean.x(), o.mean.y(), o.mean.z(), o.spread);
    out += buf;
    if (o.has_yaw) {
      std::snprintf(buf, sizeof buf, ", yaw %6.2f deg spread %.2f deg", o.yaw_mean_deg, o.yaw_spread_deg);
      out += buf;
    }
    std::snprintf(buf, sizeof buf, " over %d frames\n", o.frames);
    out += buf;
  }
  return out;
}

}  // namespace

std::string format_timing(const std::vector<RowReport>& rows) {
  std::string out;
  char buf[256];
  for (const RowReport& r : rows) {
    if (r.stats.period_stage_ms.empty()) continue;
    if (out.empty()) {
      out = "Timing, host ms per 100 ms period (CAN inputs + map clouds + ego scan; recording I/O excluded)\n";
      std::snprintf(buf, sizeof buf, "%-4s %-16s %8s %8s %8s %6s  %s\n", "Sim", "Permutation", "median",
                    "p99", "max", "worst", "worst period by stage (ms)");
      out += buf;
    }
    const TimingSummary t = summarize_timing(r.stats.period_stage_ms);
    std::snprintf(buf, sizeof buf, "%-4d %-16s %8.1f %8.1f %8.1f %6d ", r.sim, r.permutation.c_str(), t.median_ms,
                  t.p99_ms, t.max_ms, t.worst_frame);
    out += buf + stages_text(t.worst_stages_ms) + "\n";
  }
  return out;
}

std::string format_table(const std::vector<RowReport>& rows, bool aligned) {
  std::string out;
  out += aligned ? "Table 1, ALIGNED (SE(3) Umeyama per column, as the paper); metres, ours (paper)\n"
                 : "Table 1, UNALIGNED (absolute error the vehicle lives with); metres, ours (paper)\n";
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-4s %-16s %6s %6s | %-17s | %-17s | %-17s | %-17s | %-17s | %-17s\n",
                "Sim", "Permutation", "frames", "valid", "SLAM", "GPS", "Reg.", "Reg. (valid)",
                "Fused", "Fused (valid)");
  out += buf;
  for (const RowReport& r : rows) {
    const sim::PaperRow* p = sim::find_paper_row(r.sim, r.permutation);
    const sim::PaperRow none{r.sim, r.permutation, 0, 0, 0, 0, 0, 0};
    if (!p) p = &none;
    const ColumnErrors& c = aligned ? r.metrics.aligned : r.metrics.unaligned;
    std::snprintf(buf, sizeof buf, "%-4d %-16s %6d %6d | %s | %s | %s | %s | %s | %s\n", r.sim,
                  r.permutation.c_str(), r.metrics.frames, r.metrics.valid_frames,
                  cell(c.slam, p->slam).c_str(), cell(c.gps, p->gps).c_str(), cell(c.reg, p->reg).c_str(),
                  cell(c.reg_valid, p->reg_valid).c_str(), cell(c.fused, p->fused).c_str(),
                  cell(c.fused_valid, p->fused_valid).c_str());
    out += buf;
  }
  out += "GPS = horizontal error of the fixes; with the vertical error (3-D):";
  for (const RowReport& r : rows) {
    std::snprintf(buf, sizeof buf, " %.1f", aligned ? r.metrics.aligned.gps_3d : r.metrics.unaligned.gps_3d);
    out += buf;
  }
  out += " m\n";
  out += "Fused (lag): every frame after the filter's start revised the start-up frames (odometry "
         "carried back, <= 6.4 s; not the live output):";
  for (const RowReport& r : rows) {
    const double v = aligned ? r.metrics.aligned.fused_lag : r.metrics.unaligned.fused_lag;
    if (v < 0.0) {
      out += " n/a";
      continue;
    }
    std::snprintf(buf, sizeof buf, " %.3f", v);
    out += buf;
  }
  out += " m\n";
  for (const RowReport& r : rows) {
    if (r.metrics.frames_before_map == 0) continue;
    std::snprintf(buf, sizeof buf,
                  "Sim %d %s: the %d frames before the first map cloud (no map; the output is the GNSS fix) are not in "
                  "the columns\n",
                  r.sim, r.permutation.c_str(), r.metrics.frames_before_map);
    out += buf;
  }
  for (const RowReport& r : rows) {
    if (r.stats.frames_without_pose == 0) continue;
    std::snprintf(buf, sizeof buf,
                  "Sim %d %s: %d frames without a pose (late scans, or the recording ended before their period closed) are not in the columns\n",
                  r.sim, r.permutation.c_str(), r.stats.frames_without_pose);
    out += buf;
  }
  if (!aligned) out += drift_and_offset_text(rows);
  return out;
}

std::string format_json(const std::vector<RowReport>& rows) {
  Json out_rows = Json::array();
  for (const RowReport& r : rows) {
    Json row = {{"sim", r.sim},
                {"perm", r.permutation},
                {"frames", r.metrics.frames},
                {"frames_before_map", r.metrics.frames_before_map},
                {"frames_without_pose", r.stats.frames_without_pose},
                {"valid_frames", r.metrics.valid_frames},
                {"reg_ok_frames", r.metrics.reg_ok_frames},
                {"first_localized_frame", r.metrics.first_localized_frame},
                {"first_initialized_frame", r.metrics.first_initialized_frame},
                {"fused_max", number(r.metrics.fused_max)},
                {"localizer_ms_per_frame", number(r.metrics.frames ? 1e3 * r.stats.seconds / r.metrics.frames : 0.0)},
                {"localizer_max_frame_ms", number(r.stats.max_frame_ms)}};
    if (!r.stats.period_stage_ms.empty()) {
      const TimingSummary t = summarize_timing(r.stats.period_stage_ms);
      row["timing"] = {{"frame_ms", {{"median", number(t.median_ms, 3)}, {"p99", number(t.p99_ms, 3)}, {"max", number(t.max_ms, 3)}}},
                       {"worst_frame", t.worst_frame},
                       {"stages_ms", stages_json(t.worst_stages_ms)},
                       {"stages_median_ms", stages_json(t.median_stages_ms)}};
    }
    const LocalizerCounters& c = r.stats.counters;  // in-process runs (the firmware path reports its own)
    row["work"] = {{"map_clouds", r.stats.map_clouds},
                   {"map_clouds_paced", r.stats.map_clouds_paced},
                   {"map_clouds_rejected", r.stats.map_clouds_rejected},
                   {"backgrounds_loaded", r.stats.backgrounds_loaded},
                   {"map_background_checked", r.stats.map_background_checked},
                   {"map_background_mismatch", r.stats.map_background_mismatch},
                   {"map_rebuilds", c.map_rebuilds},
                   {"global_searches", c.global_searches},
                   {"basin_audits", c.basin_audits},
                   {"basin_switches", c.basin_switches},
                   {"odometry_queries", c.odometry_queries},
                   {"tracking_queries", c.tracking_queries},
                   {"map_normals", c.map_normals_computed},
                   {"audit_work", c.audit_work},
                   {"global_search_work", c.global_search_work},
                   {"odometry_query_capped", c.odometry_query_capped},
                   {"odometry_frames_thinned", c.odometry_frames_thinned},
                   {"tracking_work_capped", c.tracking_work_capped},
                   {"rebuild_steps_deferred", c.rebuild_steps_deferred},
                   {"audit_periods_starved", c.audit_periods_starved},
                   {"rival_checks_deferred", c.rival_checks_deferred},
                   {"audit_decisions_deferred", c.audit_decisions_deferred}};
    row["rpe_1s"] = {{"fused", number(r.metrics.rpe_1s.fused)},
                     {"slam", number(r.metrics.rpe_1s.slam)},
                     {"gps", number(r.metrics.rpe_1s.gps)}};
    const OffsetEstimate& o = r.metrics.offset;
    row["offset"] = {{"frames", o.frames},
                     {"mean_m", {o.mean.x(), o.mean.y(), o.mean.z()}},
                     {"spread_m", o.spread},
                     {"yaw_mean_deg", o.has_yaw ? Json(o.yaw_mean_deg) : Json(nullptr)},
                     {"yaw_spread_deg", o.has_yaw ? Json(o.yaw_spread_deg) : Json(nullptr)}};
    row["unaligned"] = columns_json(r.metrics.unaligned);
    row["aligned"] = columns_json(r.metrics.aligned);
    out_rows.push_back(std::move(row));
  }
  // nlohmann writes object keys sorted; every reader (tests, scripts) looks them up by name.
  return Json{{"rows", std::move(out_rows)}}.dump();
}

}  // namespace v2xloc::eval
