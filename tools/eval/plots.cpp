#include "tools/eval/plots.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <utility>

extern char** environ;

namespace v2xloc::eval {
namespace {

Eigen::Vector3d position(const Mat4d& m) { return m.topRightCorner<3, 1>(); }
Eigen::Vector3d position(const Pose3d& p) { return p.translation(); }

// RAII for the CSV files (fprintf keeps the number formatting explicit).
struct File {
  std::FILE* f = nullptr;
  explicit File(const std::string& path) : f(std::fopen(path.c_str(), "w")) {}
  ~File() {
    if (f) std::fclose(f);
  }
  bool close() {
    const bool ok = f && std::ferror(f) == 0 && std::fclose(f) == 0;
    f = nullptr;
    return ok;
  }
};

void put(std::FILE* f, double v) {
  if (std::isnan(v)) std::fputs(",nan", f);
  else std::fprintf(f, ",%.4f", v);
}

}  // namespace

bool write_plot_frames(const std::string& path, const std::vector<FrameRecord>& records, std::string& error) {
  if (records.empty()) {
    error = "no frames to plot";
    return false;
  }
  File file(path);
  if (!file.f) {
    error = "cannot write " + path;
    return false;
  }
  std::fputs("t,truth_x,truth_y,truth_z,gnss,gnss_x,gnss_y,slam_x,slam_y,reg_ok,reg_x,reg_y,gate_decided,gate_valid,"
             "fused_x,fused_y,lag_x,lag_y,err_gps,err_slam,err_reg,err_fused,err_fused_lag\n",
             file.f);
  const double nan = std::nan("");
  // The SLAM column: odometry anchored at the true pose of frame 0 (metrics.hpp).
  const Eigen::Isometry3d anchor =
      records.front().truth * Eigen::Isometry3d(records.front().out.odometry_pose).inverse();
  for (const FrameRecord& r : records) {
    const Eigen::Vector3d truth = r.truth.translation();
    const Eigen::Vector3d slam = anchor * position(r.out.odometry_pose);
    const bool reg_ok = r.out.registration_attempted && r.out.registration_status == RegistrationStatus::kOk;
    const Eigen::Vector3d reg = position(r.out.registration_pose);
    const Eigen::Vector3d fused = position(r.out.fused_pose);
    const Eigen::Vector3d lag = position(r.lagged_pose);
    std::fprintf(file.f, "%.3f", r.t);
    for (double v : {truth.x(), truth.y(), truth.z()}) put(file.f, v);
    std::fprintf(file.f, ",%d", r.has_gnss ? 1 : 0);
    put(file.f, r.has_gnss ? r.gnss_body.x() : nan);
    put(file.f, r.has_gnss ? r.gnss_body.y() : nan);
    put(file.f, slam.x());
    put(file.f, slam.y());
    std::fprintf(file.f, ",%d", reg_ok ? 1 : 0);
    put(file.f, reg_ok ? reg.x() : nan);
    put(file.f, reg_ok ? reg.y() : nan);
    std::fprintf(file.f, ",%d,%d", r.gate_decided ? 1 : 0, r.gate_valid ? 1 : 0);
    for (double v : {fused.x(), fused.y(), lag.x(), lag.y()}) put(file.f, v);
    put(file.f, r.has_gnss ? (r.gnss_body.head<2>() - truth.head<2>()).norm() : nan);  // horizontal, as Table 1
    put(file.f, (slam - truth).norm());
    put(file.f, reg_ok ? (reg - truth).norm() : nan);
    put(file.f, (fused - truth).norm());
    put(file.f, (lag - truth).norm());
    std::fputc('\n', file.f);
  }
  if (!file.close()) {
    error = "cannot write " + path;
    return false;
  }
  return true;
}

bool write_map_points(const std::string& path, const sim::RecordingReader& reader, std::string& error) {
  if (reader.map_clouds().empty()) {
    error = reader.dir() + ": the recording has no map clouds";
    return false;
  }
  const double cell = 0.2;  // m: finer than the plot resolves, far fewer points than the clouds
  std::map<std::pair<long, long>, Eigen::Vector3d> highest;
  cloud_io::PointCloud cloud;
  for (const sim::MapCloudInfo* info : reader.latest_map_clouds(reader.map_clouds().front().stamp)) {
    if (!reader.load_map_cloud(*info, cloud, error)) return false;
    for (const Eigen::Vector3f& p : cloud.points) {
      const Eigen::Vector3d w = info->sensor_pose * p.cast<double>();
      const std::pair<long, long> key{std::lround(std::floor(w.x() / cell)), std::lround(std::floor(w.y() / cell))};
      auto [it, inserted] = highest.emplace(key, w);
      if (!inserted && w.z() > it->second.z()) it->second = w;
    }
  }
  File file(path);
  if (!file.f) {
    error = "cannot write " + path;
    return false;
  }
  std::fputs("x,y,z\n", file.f);
  for (const auto& [key, w] : highest) std::fprintf(file.f, "%.2f,%.2f,%.2f\n", w.x(), w.y(), w.z());
  if (!file.close()) {
    error = "cannot write " + path;
    return false;
  }
  return true;
}

bool write_plot_data(const std::string& dir, const std::string& name, const sim::RecordingReader& reader,
                     const std::vector<FrameRecord>& records, std::string& error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    error = "cannot create " + dir + ": " + ec.message();
    return false;
  }
  return write_plot_frames(dir + "/" + name + "_frames.csv", records, error) &&
         write_map_points(dir + "/" + name + "_map.csv", reader, error);
}

PlotRender render_plots(const std::string& dir, const std::string& trace_dir) {
  PlotRender r;
  const char* env_python = std::getenv("V2XLOC_PYTHON");
  const char* env_script = std::getenv("V2XLOC_PLOT_SCRIPT");
  // Debian's interpreter is the one with python3-matplotlib; a venv first on PATH may lack it.
  const std::string python = env_python ? env_python : "/usr/bin/python3";
  const std::string script = env_script ? env_script : V2XLOC_PLOT_SCRIPT;
  if (!std::filesystem::exists(script)) {
    r.skipped = true;
    r.message = "plot script " + script + " not found (set V2XLOC_PLOT_SCRIPT): plot data only in " + dir;
    return r;
  }
  std::vector<std::string> args = {python, script, dir};
  if (!trace_dir.empty()) {
    args.push_back("--trace");
    args.push_back(trace_dir);
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  // The script's messages go to stderr: stdout may be carrying --json.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, STDERR_FILENO, STDOUT_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, python.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    r.skipped = true;
    r.message = "cannot run " + python + " (set V2XLOC_PYTHON): plot data only in " + dir;
    return r;
  }
  int status = 0;
  if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) {
    r.message = "plot_run.py did not finish";
    return r;
  }
  const int code = WEXITSTATUS(status);
  if (code == 3 || code == 127) {
    r.skipped = true;
    r.message = "matplotlib not available (install python3-matplotlib): plot data only in " + dir;
    return r;
  }
  r.ok = code == 0;
  if (!r.ok) r.message = "plot_run.py failed (exit " + std::to_string(code) + ")";
  return r;
}

}  // namespace v2xloc::eval
