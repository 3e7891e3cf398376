#include "tools/eval/plots.hpp"

#include <algorithm>
#include <cmath>

#include "host_sim/common/png.hpp"
#include "host_sim/common/raster.hpp"
#include "tools/eval/metrics.hpp"

namespace v2xloc::eval {
namespace {

const sim::Rgb kWhite{255, 255, 255}, kBlack{0, 0, 0}, kGrey{200, 200, 200}, kRed{220, 30, 30},
    kBlue{30, 80, 220}, kOrange{240, 150, 20}, kGreen{20, 160, 60};

Eigen::Vector2d xy(const Eigen::Vector3d& p) { return {p.x(), p.y()}; }

}  // namespace

bool write_top_view(const std::string& path, const std::vector<FrameRecord>& records, std::string& error) {
  if (records.empty()) {
    error = "no frames";
    return false;
  }
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const FrameRecord& r : records) {
    const Eigen::Vector3d p = r.truth.translation();
    x0 = std::min(x0, p.x()); y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x()); y1 = std::max(y1, p.y());
  }
  const double margin = 25.0;
  sim::Canvas canvas(x0 - margin, y0 - margin, x1 + margin, y1 + margin, 8.0, kWhite);
  for (double g = std::floor((x0 - margin) / 10) * 10; g <= x1 + margin; g += 10)
    canvas.line({g, y0 - margin}, {g, y1 + margin}, kGrey);
  for (double g = std::floor((y0 - margin) / 10) * 10; g <= y1 + margin; g += 10)
    canvas.line({x0 - margin, g}, {x1 + margin, g}, kGrey);
  std::vector<Eigen::Vector2d> truth, fused;
  for (const FrameRecord& r : records) {
    truth.push_back(xy(r.truth.translation()));
    fused.push_back(xy(r.out.fused_pose.topRightCorner<3, 1>()));
    if (r.has_gnss) canvas.cross(xy(r.gnss_body), 3, kOrange);
    if (r.out.registration_attempted && r.out.registration_status == RegistrationStatus::kOk) {
      canvas.circle(xy(r.out.registration_pose.topRightCorner<3, 1>()), 2, r.gate_valid ? kGreen : kRed);
    }
  }
  canvas.polyline(truth, kBlack, 3.0);
  canvas.polyline(fused, kBlue, 1.5);
  return sim::write_png(path, canvas.image(), error);
}

bool write_error_plot(const std::string& path, const std::vector<FrameRecord>& records, std::string& error) {
  const std::vector<double> e = fused_errors(records);
  if (e.empty()) {
    error = "no frames";
    return false;
  }
  // x: time [s] scaled to 40 px/s; y: error [cm] on a 0..max range, 8 px per cm (clipped at 10 cm).
  const double t0 = records.front().t, t1 = records.back().t;
  const double ymax = 10.0;  // cm
  sim::Canvas canvas(t0 - 0.5, -0.5, t1 + 0.5, ymax + 0.5, 40.0, kWhite);
  for (double g = 0; g <= ymax; g += 1.0) canvas.line({t0 - 0.5, g}, {t1 + 0.5, g}, g == 1.5 ? kOrange : kGrey);
  std::vector<Eigen::Vector2d> pts;
  for (std::size_t i = 0; i < e.size(); ++i) {
    pts.push_back({records[i].t, std::min(ymax, e[i] * 100.0)});
    if (records[i].gate_valid) canvas.circle(pts.back(), 2, kGreen);
  }
  canvas.polyline(pts, kBlue, 2.0);
  return sim::write_png(path, canvas.image(), error);
}

}  // namespace v2xloc::eval
