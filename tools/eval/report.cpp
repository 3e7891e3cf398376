#include "tools/eval/report.hpp"

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

std::string number(double v) {
  if (v < 0.0) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

std::string columns_json(const ColumnErrors& c) {
  return "{\"slam\":" + number(c.slam) + ",\"gps\":" + number(c.gps) + ",\"reg\":" + number(c.reg) +
         ",\"reg_valid\":" + number(c.reg_valid) + ",\"fused\":" + number(c.fused) +
         ",\"fused_valid\":" + number(c.fused_valid) + ",\"fused_ungated\":" + number(c.fused_ungated) + ",\"fused_lag\":" + number(c.fused_lag) + ",\"gps_3d\":" + number(c.gps_3d) + "}";
}

std::string stages_json(const StageMs& ms) {
  std::string out = "{";
  bool first = true;
  for (std::size_t s = 1; s < ms.size(); ++s) {  // kIdle is never charged
    if (!first) out += ",";
    first = false;
    char buf[96];
    std::snprintf(buf, sizeof buf, "\"%s\":%.3f", stage_name(static_cast<LocalizerStage>(s)), ms[s]);
    out += buf;
  }
  return out + "}";
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
  return out;
}

std::string format_json(const std::vector<RowReport>& rows) {
  std::string out = "{\"rows\":[";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const RowReport& r = rows[i];
    if (i) out += ",";
    char head[256];
    std::snprintf(head, sizeof head,
                  "{\"sim\":%d,\"perm\":\"%s\",\"frames\":%d,\"valid_frames\":%d,\"reg_ok_frames\":%d,"
                  "\"fused_max\":%s,\"localizer_ms_per_frame\":%s,\"localizer_max_frame_ms\":%s,",
                  r.sim, r.permutation.c_str(), r.metrics.frames, r.metrics.valid_frames,
                  r.metrics.reg_ok_frames, number(r.metrics.fused_max).c_str(),
                  number(r.metrics.frames ? 1e3 * r.stats.seconds / r.metrics.frames : 0.0).c_str(),
                  number(r.stats.max_frame_ms).c_str());
    out += head;
    if (!r.stats.period_stage_ms.empty()) {
      const TimingSummary t = summarize_timing(r.stats.period_stage_ms);
      char buf[256];
      std::snprintf(buf, sizeof buf, "\"timing\":{\"frame_ms\":{\"median\":%.3f,\"p99\":%.3f,\"max\":%.3f},\"worst_frame\":%d,",
                    t.median_ms, t.p99_ms, t.max_ms, t.worst_frame);
      out += buf;
      out += "\"stages_ms\":" + stages_json(t.worst_stages_ms) +
             ",\"stages_median_ms\":" + stages_json(t.median_stages_ms) + "},";
    }
    out += "\"unaligned\":" + columns_json(r.metrics.unaligned) +
           ",\"aligned\":" + columns_json(r.metrics.aligned) + "}";
  }
  out += "]}";
  return out;
}

}  // namespace v2xloc::eval
