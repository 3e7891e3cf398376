// Plot data written by v2xloc-eval --plots and the pictures tools/plots/plot_run.py draws from it.
#include "tools/eval/metrics.hpp"
#include "tools/eval/plots.hpp"

#include "host_sim/common/png.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace v2xloc::eval {
namespace {

namespace fs = std::filesystem;

std::string tmp_dir(const std::string& name) {
  const fs::path p = fs::path(V2XLOC_BINARY_DIR) / "test_tmp" / "plots" / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

Mat4d at(double x, double y) {
  Mat4d m = Mat4d::Identity();
  m(0, 3) = x;
  m(1, 3) = y;
  return m;
}

// 6 s eastbound at 7 m/s: GNSS metres off, odometry drifting, registration every other frame
// (centimetres off), the gate accepting from frame 10 on, the fused pose a few cm off.
std::vector<FrameRecord> synthetic_run() {
  std::vector<FrameRecord> records;
  for (int i = 0; i < 60; ++i) {
    FrameRecord r;
    r.t = i * 0.1;
    const double x = -30.0 + 7.0 * r.t, y = -1.75;
    r.truth = Eigen::Isometry3d(Eigen::Translation3d(x, y, 0.0));
    r.has_gnss = i % 2 == 0;
    r.gnss_body = Eigen::Vector3d(x + 4.0 * std::sin(i * 0.3), y + 3.0, 1.2);
    r.out.odometry_pose = at(7.0 * r.t * 1.01, 0.002 * i);
    r.out.registration_attempted = i % 2 == 1;
    r.out.registration_status = i % 6 == 5 ? RegistrationStatus::kDidNotConverge : RegistrationStatus::kOk;
    r.out.registration_pose = at(x + 0.03, y - 0.02);
    r.out.fused_pose = at(x + 0.01 + 0.001 * i, y);
    r.lagged_pose = r.out.fused_pose.matrix();
    r.gate_decided = i < 56;
    r.gate_valid = i >= 10 && r.gate_decided && i % 3 != 0;
    records.push_back(r);
  }
  return records;
}

// Column name -> values of a comma-separated file with a header line.
std::map<std::string, std::vector<double>> read_csv(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  std::vector<std::string> names;
  std::stringstream header(line);
  for (std::string c; std::getline(header, c, ',');) names.push_back(c);
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(f, line)) {
    std::stringstream row(line);
    std::size_t k = 0;
    for (std::string c; std::getline(row, c, ','); ++k) cols[names.at(k)].push_back(std::stod(c));
    EXPECT_EQ(k, names.size()) << line;
  }
  return cols;
}

double mean_of_finite(const std::vector<double>& v) {
  double sum = 0;
  int n = 0;
  for (double x : v)
    if (!std::isnan(x)) sum += x, ++n;
  return n ? sum / n : -1.0;
}

TEST(PlotData, ColumnMeansAreTheTableColumns) {
  const std::string dir = tmp_dir("means");
  const auto records = synthetic_run();
  std::string err;
  ASSERT_TRUE(write_plot_frames(dir + "/run_frames.csv", records, err)) << err;
  const auto cols = read_csv(dir + "/run_frames.csv");
  ASSERT_EQ(cols.at("t").size(), records.size());
  const RowMetrics m = compute_metrics(records);
  EXPECT_NEAR(mean_of_finite(cols.at("err_gps")), m.unaligned.gps, 1e-3);
  EXPECT_NEAR(mean_of_finite(cols.at("err_slam")), m.unaligned.slam, 1e-3);
  EXPECT_NEAR(mean_of_finite(cols.at("err_reg")), m.unaligned.reg, 1e-3);
  EXPECT_NEAR(mean_of_finite(cols.at("err_fused")), m.unaligned.fused, 1e-3);
  EXPECT_NEAR(mean_of_finite(cols.at("err_fused_lag")), m.unaligned.fused_lag, 1e-3);
  EXPECT_TRUE(std::isnan(cols.at("reg_x")[0]));  // frame 0 has no registration
  EXPECT_EQ(cols.at("gate_valid")[9], 0.0);      // before frame 10: not valid
  EXPECT_EQ(cols.at("gate_valid")[10], 1.0);
}

TEST(PlotData, EmptyRunAndUnwritablePathAreErrors) {
  std::string err;
  EXPECT_FALSE(write_plot_frames(tmp_dir("empty") + "/x.csv", {}, err));
  EXPECT_NE(err.find("no frames"), std::string::npos) << err;
  EXPECT_FALSE(write_plot_frames("/nonexistent/dir/x.csv", synthetic_run(), err));
  EXPECT_NE(err.find("cannot write"), std::string::npos) << err;
}

// A picture a person can read is not blank: many non-background pixels in several colours.
void expect_readable_picture(const std::string& path, int min_width, int min_height) {
  sim::ImageRgb img;
  std::string err;
  ASSERT_TRUE(sim::read_png_rgb(path, img, err)) << err;
  EXPECT_GE(img.width, min_width) << path;
  EXPECT_GE(img.height, min_height) << path;
  std::size_t non_white = 0;
  std::set<std::uint32_t> colours;
  for (std::size_t i = 0; i + 2 < img.pixels.size(); i += 3) {
    const std::uint32_t c = (std::uint32_t{img.pixels[i]} << 16) | (std::uint32_t{img.pixels[i + 1]} << 8) | img.pixels[i + 2];
    colours.insert(c);
    non_white += c != 0xFFFFFFu ? 1 : 0;
  }
  EXPECT_GT(non_white, img.pixels.size() / 3 / 50) << path << ": under 2 % drawn";
  EXPECT_GT(colours.size(), 20u) << path << ": too few colours for lines, markers, legend and text";
}

TEST(Plots, MatplotlibDrawsEveryPlotFromTheEvaluatorsFiles) {
  const std::string dir = tmp_dir("render");
  const std::string trace = tmp_dir("render_trace");
  std::string err;
  ASSERT_TRUE(write_plot_frames(dir + "/sim0_test_frames.csv", synthetic_run(), err)) << err;
  {
    std::ofstream map(dir + "/sim0_test_map.csv");
    map << "x,y,z\n";
    for (int i = 0; i < 400; ++i) map << (-40 + 0.2 * i) << "," << (i % 2 ? 6.0 : -6.0) << "," << (i % 7) << "\n";
    // A trace with per-frame timing columns (*_ms), as the evaluator's --trace may carry.
    std::ofstream tr(trace + "/sim0_test_trace.txt");
    tr << "# frame t localize_ms registration_ms\n";
    for (int i = 0; i < 60; ++i) tr << i << " " << i * 0.1 << " " << 20 + i % 7 << " " << 12 + i % 5 << "\n";
  }
  const PlotRender r = render_plots(dir, trace);
  if (r.skipped) GTEST_SKIP() << r.message;
  ASSERT_TRUE(r.ok) << r.message;
  expect_readable_picture(dir + "/sim0_test_topview.png", 700, 500);
  expect_readable_picture(dir + "/sim0_test_error.png", 800, 450);
  expect_readable_picture(dir + "/sim0_test_timing.png", 800, 350);

  // Without timing in the outputs the timing plot is skipped, the others are still drawn.
  fs::remove(dir + "/sim0_test_timing.png");
  const PlotRender no_trace = render_plots(dir, "");
  ASSERT_TRUE(no_trace.ok) << no_trace.message;
  EXPECT_FALSE(fs::exists(dir + "/sim0_test_timing.png"));
  EXPECT_TRUE(fs::exists(dir + "/sim0_test_error.png"));
}

TEST(Plots, BadPlotDataIsAnError) {
  const std::string dir = tmp_dir("bad");
  std::ofstream(dir + "/x_frames.csv") << "t,truth_x\n0,1\n";
  const PlotRender r = render_plots(dir, "");
  if (r.skipped) GTEST_SKIP() << r.message;
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("exit 2"), std::string::npos) << r.message;
}

}  // namespace
}  // namespace v2xloc::eval
