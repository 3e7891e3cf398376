// The verdict of a registration as JSON, shared by v2xloc-register and v2xloc-dataset:
//   {"verdict": "ok|unreliable|failed", "reasons": [...], "evidence": {...}, "thresholds": {...}}
// and the status word both tools print ("ok", "unreliable", or the failed registration's status).
#pragma once

#include "v2xloc/algo/registration/registration_verdict.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace v2xloc::tools {

inline std::string verdict_status(const RegistrationVerdict& v) {
  if (v.verdict == Verdict::kFailed) return to_string(v.evidence.status);
  return to_string(v.verdict);
}

inline std::string verdict_reasons_text(const RegistrationVerdict& v) {
  std::string out;
  for (std::uint32_t i = 0; i < kVerdictReasonCount; ++i) {
    if ((v.reasons & (1u << i)) == 0) continue;
    if (!out.empty()) out += ",";
    out += verdict_reason_name(i);
  }
  return out.empty() ? "-" : out;
}

inline nlohmann::ordered_json verdict_json(const RegistrationVerdict& v, const VerdictParams& p) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); };
  Json reasons = Json::array();
  for (std::uint32_t i = 0; i < kVerdictReasonCount; ++i) {
    if (v.reasons & (1u << i)) reasons.push_back(verdict_reason_name(i));
  }
  const VerdictEvidence& e = v.evidence;
  Json evidence;
  evidence["registration_status"] = to_string(e.status);
  evidence["fitness"] = num(e.fitness);
  evidence["inliers"] = e.inliers;
  evidence["inlier_rmse_m"] = num(e.inlier_rmse);
  evidence["converged"] = e.converged;
  evidence["tilt_deg"] = num(e.tilt_deg);
  if (e.has_runner_up) {
    evidence["runner_up"] = {{"fitness", num(e.runner_up_fitness)}, {"ratio", num(e.runner_up_ratio)},
                             {"distance_m", num(e.runner_up_distance_m)}, {"yaw_deg", num(e.runner_up_yaw_deg)}};
  }
  Json thresholds;
  thresholds["min_fitness"] = p.min_fitness;
  thresholds["min_inliers"] = p.min_inliers;
  thresholds["max_tilt_deg"] = p.max_tilt_deg;
  thresholds["max_runner_up_ratio"] = p.max_runner_up_ratio;
  thresholds["min_fitness_not_converged"] = p.min_fitness_not_converged;
  return Json{{"verdict", to_string(v.verdict)}, {"reasons", reasons}, {"evidence", evidence}, {"thresholds", thresholds}};
}

}  // namespace v2xloc::tools
