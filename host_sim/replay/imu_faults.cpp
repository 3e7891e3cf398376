#include "host_sim/replay/imu_faults.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <utility>

#include "hal/hid_imu_report.hpp"
#include "host_sim/common/rng.hpp"

namespace v2xloc::sim::replay {
namespace {

namespace hid = hal::hid_imu;

const char* const kAxes[] = {"gx", "gy", "gz", "ax", "ay", "az"};

double seconds(const hal::HidScriptLine& r) { return static_cast<double>(r.timestamp_ns) * 1e-9; }

std::int16_t& axis(hid::RawReport& r, int k) { return k < 3 ? r.gyro[k] : r.accel[k - 3]; }

// Decodes, alters and re-encodes one report; false (unchanged) for a report that does not decode.
template <class Alter>
bool rewrite(hal::HidScriptLine& line, Alter alter) {
  hid::RawReport raw;
  if (hid::decode_input_report(std::span<const std::uint8_t>(line.bytes.data(), line.size), raw) != hal::Status::kOk)
    return false;
  alter(raw);
  hid::encode_input_report(raw, line.bytes);
  return true;
}

void sensor_faults(const ImuFaultSpec& spec, std::vector<hal::HidScriptLine>& reports, ImuFaultStats& stats) {
  bool have_stuck = false;
  std::int16_t stuck_value = 0;
  for (hal::HidScriptLine& r : reports) {
    const double t = seconds(r);
    if (spec.stuck_axis >= 0 && t >= spec.stuck_at_s) {
      const bool changed = rewrite(r, [&](hid::RawReport& raw) {
        if (!have_stuck) stuck_value = axis(raw, spec.stuck_axis);
        have_stuck = true;
        axis(raw, spec.stuck_axis) = stuck_value;
      });
      if (changed) ++stats.stuck;
    }
    if (spec.bias_step_dps != 0 && t >= spec.bias_step_at_s) {
      const double step_lsb = std::nearbyint(spec.bias_step_dps / hid::kGyroDegPerSecondPerLsb);
      const bool changed = rewrite(r, [&](hid::RawReport& raw) {
        raw.gyro[2] = static_cast<std::int16_t>(std::clamp(raw.gyro[2] + step_lsb, -32767.0, 32767.0));
      });
      if (changed) ++stats.biased;
    }
  }
}

void transport_faults(const ImuFaultSpec& spec, std::uint64_t seed, std::vector<hal::HidScriptLine>& reports,
                      ImuFaultStats& stats) {
  Rng rng(derive_seed(seed, {0x494D55u}));  // "IMU": a stream of its own
  std::vector<hal::HidScriptLine> out;
  out.reserve(reports.size());
  for (const hal::HidScriptLine& r : reports) {
    const double t = seconds(r);
    if (spec.dropout_s > 0 && t >= spec.dropout_at_s && t < spec.dropout_at_s + spec.dropout_s) {
      ++stats.dropped;
      continue;
    }
    out.push_back(r);
    if (spec.repeat > 0 && rng.bernoulli(spec.repeat)) {
      out.push_back(r);
      ++stats.repeated;
    }
  }
  if (spec.reorder > 0) {
    for (std::size_t i = 0; i + 1 < out.size(); ++i) {
      if (rng.bernoulli(spec.reorder)) {
        // The earlier report is held back behind the later one: both arrive at the later time.
        std::swap(out[i], out[i + 1]);
        out[i + 1].timestamp_ns = out[i].timestamp_ns;
        ++stats.reordered;
        ++i;
      }
    }
  }
  reports.swap(out);
}

}  // namespace

bool parse_fault_number(const std::string& text, double lo, double hi, double& out) {
  char* end = nullptr;
  const double d = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !(d >= lo && d <= hi)) return false;
  out = d;
  return true;
}

bool parse_imu_fault(const std::string& key, const std::string& value, ImuFaultSpec& spec, bool& ok) {
  ok = true;
  if (key == "imu-dropout") ok = parse_fault_number(value, 0.0, 1e6, spec.dropout_s);
  else if (key == "imu-dropout-at") ok = parse_fault_number(value, 0.0, 1e6, spec.dropout_at_s);
  else if (key == "imu-stuck-at") ok = parse_fault_number(value, 0.0, 1e6, spec.stuck_at_s);
  else if (key == "imu-bias-step") ok = parse_fault_number(value, -300.0, 300.0, spec.bias_step_dps);
  else if (key == "imu-bias-step-at") ok = parse_fault_number(value, 0.0, 1e6, spec.bias_step_at_s);
  else if (key == "imu-repeat") ok = parse_fault_number(value, 0.0, 1.0, spec.repeat);
  else if (key == "imu-reorder") ok = parse_fault_number(value, 0.0, 1.0, spec.reorder);
  else if (key == "imu-stuck") {
    ok = false;
    for (int k = 0; k < 6; ++k) {
      if (value == kAxes[k]) {
        spec.stuck_axis = k;
        ok = true;
      }
    }
  } else {
    return false;
  }
  return true;
}

std::string describe(const ImuFaultSpec& f) {
  std::ostringstream o;
  if (f.dropout_s > 0) o << " imu-dropout=" << f.dropout_s << "@" << f.dropout_at_s;
  if (f.stuck_axis >= 0) o << " imu-stuck=" << kAxes[f.stuck_axis] << "@" << f.stuck_at_s;
  if (f.bias_step_dps != 0) o << " imu-bias-step=" << f.bias_step_dps << "@" << f.bias_step_at_s;
  if (f.repeat > 0) o << " imu-repeat=" << f.repeat;
  if (f.reorder > 0) o << " imu-reorder=" << f.reorder;
  return o.str();
}

void apply_imu_faults(const ImuFaultSpec& spec, std::uint64_t seed, std::vector<hal::HidScriptLine>& reports,
                      ImuFaultStats& stats) {
  if (!spec.any()) return;
  sensor_faults(spec, reports, stats);
  transport_faults(spec, seed, reports, stats);
}

}  // namespace v2xloc::sim::replay
