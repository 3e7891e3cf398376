#include "host_sim/recording/recording_reader.hpp"

#include "firmware/protocol/can_message_types.hpp"
#include "host_sim/canlog/candump_log.hpp"
#include "host_sim/cloud_io/pcd.hpp"
#include "host_sim/common/text_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>

namespace v2xloc::sim {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxPathChars = 1024;
constexpr std::int64_t kMaxCloudPoints = 100'000'000;
constexpr std::size_t kMaxCanLogLines = 100'000'000;

// Field readers over one JSON object. Each names the field and the reason it is refused.
class Fields {
 public:
  Fields(const Json& obj, std::string where, std::string& error) : obj_(obj), where_(std::move(where)), error_(error) {}

  const Json* find(const char* key) const {
    if (!obj_.is_object()) return nullptr;
    const auto it = obj_.find(key);
    return it == obj_.end() ? nullptr : &*it;
  }
  bool fail(const char* key, const std::string& why) const {
    error_ = where_ + key + ": " + why;
    return false;
  }
  bool object(const char* key, const Json*& out) const {
    out = find(key);
    return out && out->is_object() ? true : fail(key, "missing or not an object");
  }
  bool string(const char* key, std::string& out, bool required = true) const {
    const Json* v = find(key);
    if (!v) return required ? fail(key, "missing") : true;
    if (!v->is_string()) return fail(key, "not a string");
    out = v->get<std::string>();
    return true;
  }
  bool number(const char* key, double lo, double hi, double& out) const {
    const Json* v = find(key);
    if (!v || !v->is_number()) return fail(key, "missing or not a number");
    const double d = v->get<double>();
    if (!std::isfinite(d) || d < lo || d > hi)
      return fail(key, "out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = d;
    return true;
  }
  bool integer(const char* key, std::int64_t lo, std::int64_t hi, std::int64_t& out) const {
    const Json* v = find(key);
    if (!v || !v->is_number_integer()) return fail(key, "missing or not an integer");
    const bool too_big = v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(hi);
    const std::int64_t i = too_big ? hi : v->get<std::int64_t>();
    if (too_big || i < lo || i > hi)
      return fail(key, "out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    out = i;
    return true;
  }
  bool pose(const char* key, Eigen::Isometry3d& out) const {
    const Json* v = find(key);
    return v && pose_from_json(*v, out) ? true : fail(key, "want [x, y, z, qx, qy, qz, qw], finite, unit quaternion");
  }
  bool path(const char* key, std::string& out, bool required = true) const;

 private:
  const Json& obj_;
  std::string where_;
  std::string& error_;
};

// What a recording in a format this build does not read is told to do.
constexpr const char* kRegenerate =
    "this build reads only what it writes: make the recording again (v2xloc-sim generate --scenario N --perm P"
    " --out DIR, or --all; v2xloc-dataset dair-v2x-c ROOT --recording DIR for the DAIR-V2X-C drive)";

// format_version: exactly kFormatVersion. Older recordings (1: float32 PCD clouds, no version
// field) and newer ones are refused by name, with the command that makes them again.
bool check_format_version(const Fields& top) {
  const Json* v = top.find("format_version");
  if (v == nullptr) return top.fail("format_version", "missing (a format-1 recording); " + std::string(kRegenerate));
  if (!v->is_number_integer() || v->get<std::int64_t>() != RecordingReader::kFormatVersion)
    return top.fail("format_version", v->dump() + ", not " + std::to_string(RecordingReader::kFormatVersion) + "; " +
                                          kRegenerate);
  return true;
}

// can_log.layout_version (with a CAN log): exactly the layout the firmware decodes.
bool check_can_layout_version(const Fields& top) {
  const Json* can = top.find("can_log");
  const Json* v = can != nullptr && can->is_object() && can->contains("layout_version") ? &(*can)["layout_version"] : nullptr;
  if (v == nullptr)
    return top.fail("can_log.layout_version", "missing (a CAN layout 1 log); " + std::string(kRegenerate));
  if (!v->is_number_integer() || v->get<std::int64_t>() != protocol::kCanLayoutVersion)
    return top.fail("can_log.layout_version",
                    v->dump() + ", not " + std::to_string(protocol::kCanLayoutVersion) + "; " + kRegenerate);
  return true;
}

// A relative path inside the recording: no absolute paths, no "..", no control characters.
bool plain_relative_path(const std::string& rel, std::string& why) {
  if (rel.empty() || rel.size() > kMaxPathChars) {
    why = "empty or longer than " + std::to_string(kMaxPathChars) + " characters";
    return false;
  }
  if (rel.front() == '/') {
    why = "absolute path";
    return false;
  }
  for (unsigned char c : rel) {
    if (c < 0x20 || c == 0x7f || c == '\\') {
      why = "control character or backslash in path";
      return false;
    }
  }
  std::size_t start = 0;
  while (start <= rel.size()) {
    const std::size_t end = std::min(rel.find('/', start), rel.size());
    if (rel.compare(start, end - start, "..") == 0 && end - start == 2) {
      why = "'..' leaves the recording";
      return false;
    }
    start = end + 1;
  }
  return true;
}

bool Fields::path(const char* key, std::string& out, bool required) const {
  std::string value;
  if (!string(key, value, required)) return false;
  if (value.empty() && !find(key)) return true;  // optional and absent
  std::string why;
  if (!plain_relative_path(value, why)) return fail(key, why);
  out = value;
  return true;
}

// frame_stamps_s (optional): one finite stamp per frame, strictly increasing.
bool read_frame_stamps(const Fields& top, int frame_count, std::vector<double>& out) {
  const Json* stamps = top.find("frame_stamps_s");
  if (stamps == nullptr) return true;
  if (!stamps->is_array() || stamps->size() != static_cast<std::size_t>(frame_count))
    return top.fail("frame_stamps_s", "want an array of frame_count stamps");
  for (const Json& v : *stamps) {
    const double t = v.is_number() ? v.get<double>() : std::nan("");
    if (!std::isfinite(t) || std::abs(t) > 1e7 || (!out.empty() && !(t > out.back())))
      return top.fail("frame_stamps_s", "stamps must be finite, within 1e7 s and strictly increasing");
    out.push_back(t);
  }
  return true;
}

// gnss.antenna_in_body (optional): [x, y, z] metres, each within 100 m of the body origin.
bool read_gnss_antenna(const Fields& top, bool& has, Eigen::Vector3d& out) {
  const Json* gnss = top.find("gnss");
  if (gnss == nullptr || !gnss->is_object() || !gnss->contains("antenna_in_body")) return true;
  const Json& a = (*gnss)["antenna_in_body"];
  if (!a.is_array() || a.size() != 3) return top.fail("gnss.antenna_in_body", "want [x, y, z]");
  for (int k = 0; k < 3; ++k) {
    const double v = a[static_cast<std::size_t>(k)].is_number() ? a[static_cast<std::size_t>(k)].get<double>() : std::nan("");
    if (!std::isfinite(v) || std::abs(v) > 100.0) return top.fail("gnss.antenna_in_body", "want finite metres within 100 m");
    out[k] = v;
  }
  has = true;
  return true;
}

}  // namespace

bool RecordingReader::parse_index_pattern(const std::string& text, IndexPattern& out, std::string& error) {
  // Exactly one "%0Nd" and no other '%': the pattern is data, never handed to printf.
  const std::size_t pct = text.find('%');
  if (pct == std::string::npos || text.find('%', pct + 1) != std::string::npos || pct + 4 > text.size() ||
      text[pct + 1] != '0' || text[pct + 2] < '1' || text[pct + 2] > '9' || text[pct + 3] != 'd') {
    error = "want exactly one %0Nd frame-index token (N = 1..9), e.g. ego_lidar/%06d.pcd";
    return false;
  }
  IndexPattern p;
  p.prefix = text.substr(0, pct);
  p.suffix = text.substr(pct + 4);
  p.width = text[pct + 2] - '0';
  if (!plain_relative_path(p.format(0), error)) return false;
  out = std::move(p);
  return true;
}

std::string RecordingReader::IndexPattern::format(int index) const {
  std::string digits = std::to_string(index);
  if (digits.size() < static_cast<std::size_t>(width)) digits.insert(0, static_cast<std::size_t>(width) - digits.size(), '0');
  return prefix + digits + suffix;
}

bool RecordingReader::resolve(const std::string& rel, std::string& path, std::string& error) const {
  std::string why;
  if (!plain_relative_path(rel, why)) {
    error = dir_ + ": " + rel + ": " + why;
    return false;
  }
  // Symbolic links may still point elsewhere: compare the real location with the folder's.
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(fs::path(real_dir_) / rel, ec);
  const fs::path root(real_dir_);
  if (ec || std::mismatch(root.begin(), root.end(), real.begin(), real.end()).first != root.end()) {
    error = dir_ + ": " + rel + " resolves outside the recording";
    return false;
  }
  path = dir_ + "/" + rel;
  return true;
}

bool RecordingReader::open(const std::string& dir, std::string& error) {
  *this = RecordingReader{};
  dir_ = dir;
  std::error_code ec;
  real_dir_ = fs::canonical(dir, ec).string();
  if (ec) {
    error = "cannot open recording " + dir + ": " + ec.message();
    return false;
  }
  std::string text;
  if (!read_text_file(dir + "/manifest.json", kMaxManifestBytes, text, error)) return false;
  if (!parse_manifest(text, error)) {
    error = dir + "/manifest.json: " + error;
    return false;
  }
  std::string path;
  if (!resolve(gt_file_, path, error) || !read_tum(path, gt_, error)) return false;
  if (gt_.size() != static_cast<std::size_t>(frame_count_)) {
    error = path + ": " + std::to_string(gt_.size()) + " poses for frame_count " + std::to_string(frame_count_);
    return false;
  }
  if (!resolve(gt100_file_, path, error) || !read_tum(path, gt100_, error)) return false;
  if (gt100_.empty()) {
    error = path + ": no poses";
    return false;
  }
  return true;
}

bool RecordingReader::parse_manifest(const std::string& text, std::string& error) {
  {
    RecordingReader fresh;  // nothing of an earlier manifest survives
    fresh.dir_ = std::move(dir_);
    fresh.real_dir_ = std::move(real_dir_);
    *this = std::move(fresh);
  }
  Json m;
  try {
    m = Json::parse(text);
  } catch (const Json::exception& e) {
    error = std::string("not valid JSON: ") + e.what();
    return false;
  }
  const Fields top(m, "", error);
  std::string format;
  if (!top.string("format", format)) return false;
  if (format != "v2xloc-recording") return top.fail("format", "not a v2xloc recording");
  return check_format_version(top) && read_timing_and_origin(m, error) && read_files(m, error) &&
         read_sensors(m, error) && read_map_clouds(m, error);
}

// Scenario id, permutation, frames and their stamps, time and geodetic origin, the simulator's
// seed and set-up, the GNSS lever arm.
bool RecordingReader::read_timing_and_origin(const Json& m, std::string& error) {
  const Fields top(m, "", error);
  const Json *scenario = nullptr, *geo = nullptr;
  std::int64_t count = 0, id = 0;
  if (!top.object("scenario", scenario) || !Fields(*scenario, "scenario.", error).integer("id", 0, 1'000'000, id) ||
      !top.string("permutation", permutation_) || !top.integer("frame_count", 1, kMaxFrames, count) ||
      !top.number("frame_rate_hz", 0.1, 1000.0, frame_rate_) ||
      !top.number("time_origin_unix_s", 0.0, 1e11, time_origin_unix_) || !top.object("geodetic_origin", geo))
    return false;
  scenario_ = static_cast<int>(id);
  frame_count_ = static_cast<int>(count);
  if (!read_frame_stamps(top, frame_count_, frame_stamps_) || !read_gnss_antenna(top, has_gnss_antenna_, gnss_antenna_))
    return false;
  if (top.find("seed")) {  // written as a JSON number; an integer up to 2^53 survives a double
    double seed = 0.0;
    if (!top.number("seed", 0.0, 9007199254740992.0, seed)) return false;
    if (seed != std::floor(seed)) return top.fail("seed", "not an integer");
    seed_ = static_cast<std::uint64_t>(seed);
  }
  if (const Json* quick = top.find("quick")) {
    if (!quick->is_boolean()) return top.fail("quick", "not true or false");
    quick_ = quick->get<bool>();
  }
  const Fields g(*geo, "geodetic_origin.", error);
  return g.number("lat_deg", -90, 90, origin_lat_deg_) && g.number("lon_deg", -180, 180, origin_lon_deg_) &&
         g.number("alt_m", -1e4, 1e5, origin_alt_m_);
}

// files: the per-frame patterns, ground truth, CAN log (in the current layout) and trust list.
bool RecordingReader::read_files(const Json& m, std::string& error) {
  const Fields top(m, "", error);
  const Json* files = nullptr;
  if (!top.object("files", files)) return false;
  const Fields f(*files, "files.", error);
  std::string scan, disparity;
  if (!f.string("ego_scan_pattern", scan) || !f.string("disparity_pattern", disparity, false) ||
      !f.path("ground_truth", gt_file_) || !f.path("ground_truth_100hz", gt100_file_) ||
      !f.path("can_log", can_log_file_, false) || !f.path("trust_list", trust_list_file_) ||
      !f.path("imu_reports", imu_reports_file_, false))
    return false;
  if (!can_log_file_.empty() && !check_can_layout_version(top)) return false;
  std::string why;
  if (!parse_index_pattern(scan, scan_pattern_, why)) return f.fail("ego_scan_pattern", why);
  if (f.find("disparity_pattern") && !parse_index_pattern(disparity, disparity_pattern_, why))
    return f.fail("disparity_pattern", why);
  return true;
}

// sensors: the ego LiDAR's mount (required), the stereo calibration when the recording has
// disparity maps, every infrastructure unit's surveyed pose.
bool RecordingReader::read_sensors(const Json& m, std::string& error) {
  const Fields top(m, "", error);
  const Json* sensors = top.find("sensors");
  if (!sensors || !sensors->is_array()) return top.fail("sensors", "missing or not an array");
  bool have_ego_lidar = false;
  for (std::size_t k = 0; k < sensors->size(); ++k) {
    const std::string where = "sensors[" + std::to_string(k) + "].";
    const Fields s((*sensors)[k], where, error);
    std::string name, carrier;
    if (!s.string("name", name) || !s.string("carrier", carrier, false)) return false;
    if (name == "ego_lidar") {
      if (!s.pose("mount_in_body", ego_lidar_mount_)) return false;
      have_ego_lidar = true;
    }
    if (name == "ego_stereo" && disparity_pattern_.width > 0 && !read_stereo_calibration((*sensors)[k], where, error))
      return false;
    if (carrier == "infrastructure") {
      Eigen::Isometry3d p;
      if (!s.pose("surveyed_pose_enu", p)) return false;
      infra_poses_.push_back(p);
      infra_names_.push_back(name);
    }
  }
  return have_ego_lidar ? true : top.fail("sensors", "no ego_lidar entry");
}

bool RecordingReader::read_stereo_calibration(const Json& entry, const std::string& where, std::string& error) {
  const Fields s(entry, where, error);
  std::int64_t w = 0, h = 0;
  if (!s.integer("width", 1, 65535, w) || !s.integer("height", 1, 65535, h) || !s.number("fx", 1e-3, 1e7, stereo_.fx) ||
      !s.number("fy", 1e-3, 1e7, stereo_.fy) || !s.number("cx", -1e7, 1e7, stereo_.cx) ||
      !s.number("cy", -1e7, 1e7, stereo_.cy) || !s.number("baseline_m", 1e-4, 100, stereo_.baseline) ||
      !s.number("disparity_sigma_px", 0, 1e3, stereo_.disparity_sigma_px) ||
      !s.pose("camera_to_body", stereo_.camera_to_body))
    return false;
  stereo_.width = static_cast<int>(w);
  stereo_.height = static_cast<int>(h);
  has_stereo_ = true;
  return true;
}

// map_clouds.clouds: every published cloud with its reported and true pose, sorted by stamp.
bool RecordingReader::read_map_clouds(const Json& m, std::string& error) {
  const Fields top(m, "", error);
  const Json* map = top.find("map_clouds");
  const Json* clouds = map && map->is_object() && map->contains("clouds") ? &(*map)["clouds"] : nullptr;
  if (!clouds || !clouds->is_array()) return top.fail("map_clouds.clouds", "missing or not an array");
  for (std::size_t k = 0; k < clouds->size(); ++k) {
    const Fields c((*clouds)[k], "map_clouds.clouds[" + std::to_string(k) + "].", error);
    MapCloudInfo info;
    std::int64_t points = 0;
    if (!c.string("sensor", info.sensor) || !c.string("kind", info.kind) ||
        !c.number("stamp_s", -1e7, 1e7, info.stamp) || !c.path("file", info.file) ||
        !c.integer("points", 0, kMaxCloudPoints, points) || !c.pose("sensor_pose_enu", info.sensor_pose) ||
        !c.pose("true_sensor_pose_enu", info.true_sensor_pose))
      return false;
    if (info.kind != "infra" && info.kind != "agent") return c.fail("kind", "want \"infra\" or \"agent\"");
    if (info.sensor.empty() || info.sensor.size() > 64) return c.fail("sensor", "empty or longer than 64 characters");
    info.points = static_cast<std::size_t>(points);
    map_clouds_.push_back(std::move(info));
  }
  std::stable_sort(map_clouds_.begin(), map_clouds_.end(),
                   [](const MapCloudInfo& a, const MapCloudInfo& b) { return a.stamp < b.stamp; });
  return true;
}

bool RecordingReader::ego_scan(int i, cloud_io::PointCloud& out, std::string& error) const {
  if (i < 0 || i >= frame_count_) {
    error = "frame index out of range";
    return false;
  }
  std::string path;
  return resolve(scan_pattern_.format(i), path, error) && cloud_io::read_pcd(path, out, error);
}

Eigen::Isometry3d RecordingReader::ground_truth_at(double t) const {
  if (gt100_.empty()) return Eigen::Isometry3d::Identity();
  if (!(t > gt100_.front().t)) return gt100_.front().pose;  // also NaN
  if (t >= gt100_.back().t) return gt100_.back().pose;
  const auto it = std::upper_bound(gt100_.begin(), gt100_.end(), t, [](double v, const TimedPose& p) { return v < p.t; });
  const TimedPose& b = *it;
  const TimedPose& a = *(it - 1);
  const double s = (t - a.t) / (b.t - a.t);  // read_tum guarantees b.t > a.t
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.translation() = (1 - s) * a.pose.translation() + s * b.pose.translation();
  out.linear() = Eigen::Quaterniond(a.pose.linear()).slerp(s, Eigen::Quaterniond(b.pose.linear())).toRotationMatrix();
  return out;
}

bool RecordingReader::disparity(int i, Image16& out, std::string& error) const {
  if (!has_stereo_) {
    error = "recording has no stereo";
    return false;
  }
  if (i < 0 || i >= frame_count_) {
    error = "frame index out of range";
    return false;
  }
  std::string path;
  return resolve(disparity_pattern_.format(i), path, error) && read_png16(path, out, error);
}

std::vector<const MapCloudInfo*> RecordingReader::map_clouds_until(double t) const {
  std::vector<const MapCloudInfo*> out;
  for (const auto& m : map_clouds_)
    if (m.stamp <= t + 1e-9) out.push_back(&m);
  return out;
}

std::vector<const MapCloudInfo*> RecordingReader::latest_map_clouds(double t) const {
  std::vector<const MapCloudInfo*> out;
  for (const auto& m : map_clouds_) {
    if (m.stamp > t + 1e-9) break;
    auto it = std::find_if(out.begin(), out.end(), [&](const MapCloudInfo* o) { return o->sensor == m.sensor; });
    if (it == out.end()) out.push_back(&m);
    else *it = &m;
  }
  return out;
}

bool RecordingReader::load_map_cloud(const MapCloudInfo& info, cloud_io::PointCloud& out, std::string& error) const {
  std::string path;
  return resolve(info.file, path, error) && cloud_io::read_pcd(path, out, error);
}

std::string RecordingReader::trust_list_path() const { return dir_ + "/" + trust_list_file_; }

std::string RecordingReader::can_log_path() const {
  return can_log_file_.empty() ? std::string() : dir_ + "/" + can_log_file_;
}

std::string RecordingReader::imu_reports_path() const {
  return imu_reports_file_.empty() ? std::string() : dir_ + "/" + imu_reports_file_;
}

bool RecordingReader::open_listed(const std::string& file, const char* what, std::ifstream& in, std::string& path,
                                  std::string& error) const {
  if (file.empty()) {
    error = std::string("recording has no ") + what;
    return false;
  }
  if (!resolve(file, path, error)) return false;
  in.open(path);
  if (!in) {
    error = "cannot open " + path;
    return false;
  }
  return true;
}

bool RecordingReader::imu_reports(std::vector<hal::HidScriptLine>& out, std::string& error) const {
  out.clear();
  std::string path;
  std::ifstream in;
  if (!open_listed(imu_reports_file_, "IMU reports", in, path, error)) return false;
  std::string line;
  std::size_t number = 0;
  hal::HidScriptLine report;
  while (std::getline(in, line)) {
    ++number;
    const hal::HidScriptParse parsed = hal::parse_hid_script_line(line.c_str(), report);
    if (parsed == hal::HidScriptParse::kBlank) continue;
    if (parsed == hal::HidScriptParse::kMalformed || (!out.empty() && report.timestamp_ns < out.back().timestamp_ns)) {
      error = path + ":" + std::to_string(number) + ": not \"<time_ns> <hex bytes>\" in time order";
      return false;
    }
    out.push_back(report);
  }
  return true;
}

bool RecordingReader::can_records(std::vector<CandumpRecord>& out, std::string& error) const {
  out.clear();
  std::string path;
  std::ifstream in;
  if (!open_listed(can_log_file_, "CAN log", in, path, error)) return false;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty()) continue;
    CandumpRecord r;
    std::string why;
    if (number > kMaxCanLogLines || !parse_candump_line(line, r, why)) {
      error = path + " line " + std::to_string(number) + ": " + (why.empty() ? "too many lines" : why);
      return false;
    }
    out.push_back(std::move(r));
  }
  return true;
}

bool RecordingReader::can_frames(std::vector<CanLogFrame>& out, std::string& error) const {
  out.clear();
  std::vector<CandumpRecord> records;
  if (!can_records(records, error)) return false;
  out.reserve(records.size());
  for (CandumpRecord& r : records) {
    CanLogFrame f;
    // Exact integer microseconds -> seconds (the division rounds once, like parsing the decimal text).
    f.t = static_cast<double>(r.timestamp_us) / 1e6 - time_origin_unix_;
    f.interface = std::move(r.interface);
    f.id = r.frame.id;
    f.dlc = r.frame.dlc;
    std::copy(r.frame.data, r.frame.data + 8, f.data);
    out.push_back(f);
  }
  return true;
}

}  // namespace v2xloc::sim
