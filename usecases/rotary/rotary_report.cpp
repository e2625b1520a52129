#include "usecases/rotary/rotary_report.h"

#include <cmath>
#include <cstdio>
#include <utility>

#include "analysis/core/errors.h"

namespace km::usecases {
namespace {

using nlohmann::json;

std::string Fixed(double v, int digits) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

std::vector<std::string> RotaryWarnings(const RotaryReport& r) {
  std::vector<std::string> w;
  const auto& res = r.result;
  for (const auto& g : res.not_separable) w.push_back(g.sentence);
  if (!res.converged) {
    w.push_back("the identification did not converge in " + std::to_string(res.iterations) +
                " iterations");
  }
  const auto& u = r.file.u_reading_um;
  if (u && *u > 0.0 && res.sigma_um > 3.0 * *u) {
    w.push_back("the residual's standard deviation " + Fixed(res.sigma_um, 2) +
                " µm is more than three times u_reading_um (" + Fixed(*u, 2) +
                " µm): the model leaves an effect unexplained");
  }
  return w;
}

json ErrorsJson(const RotaryReport& r) {
  json out = json::object();
  const auto k = r.result.kinematics;
  for (std::size_t i = 0; i < rotary::kLocationErrorCount; ++i) {
    const auto& e = r.result.errors[i];
    out[LocationErrorKey(k, i)] = {{"value", e.identifiable ? json(e.value) : json(nullptr)},
                                   {"sigma", e.identifiable ? json(e.sigma) : json(nullptr)},
                                   {"identifiable", e.identifiable}};
  }
  return out;
}

json SeparabilityJson(const RotaryReport& r, json& not_identifiable) {
  json groups = json::array();
  const auto& names = rotary::LocationErrorNames(r.result.kinematics);
  for (std::size_t i = 0; i < rotary::kLocationErrorCount; ++i) {
    if (!r.result.errors[i].identifiable) not_identifiable.push_back(std::string(names[i]));
  }
  for (const auto& g : r.result.not_separable) {
    json members = json::array();
    for (std::size_t i : g.errors) members.push_back(std::string(names[i]));
    groups.push_back({{"errors", members},
                      {"determined", g.determined.empty() ? json(nullptr) : json(g.determined)},
                      {"sentence", g.sentence}});
  }
  return groups;
}

json PosesJson(const RotaryReport& r) {
  const std::string tilt =
      r.result.kinematics == rotary::Kinematics::kAcTrunnion ? "a_deg" : "b_deg";
  json out = json::array();
  for (std::size_t i = 0; i < r.file.test.poses.size(); ++i) {
    const auto& p = r.file.test.poses[i];
    const auto& res = r.result.residuals_um[i];
    out.push_back({{tilt, p.tilt_deg},
                   {"c_deg", p.c_deg},
                   {"measured_um", p.d_um},
                   {"residual_um", res},
                   {"residual_norm_um", std::hypot(res[0], res[1], res[2])}});
  }
  return out;
}

}  // namespace

std::string LocationErrorKey(rotary::Kinematics k, std::size_t index) {
  return std::string(rotary::LocationErrorNames(k)[index]) +
         (rotary::IsAngularError(index) ? "_urad" : "_um");
}

RotaryReport AnalyseRotary(ingest::RotaryFile file) {
  RotaryReport r;
  try {
    r.result = rotary::IdentifyLocationErrors(file.test);
  } catch (const InvalidInput& e) {
    throw InvalidInput(file.file, e.line(), e.field(), e.reason());
  }
  r.file = std::move(file);
  r.warnings = RotaryWarnings(r);
  return r;
}

json RotaryReportToJson(const RotaryReport& r) {
  const auto& res = r.result;
  const auto& setup = r.file.test.setup;
  json not_identifiable = json::array();
  json j;
  j["analysis_version"] = kRotaryAnalysisVersion;
  j["machine_id"] = r.file.machine_id;
  j["test_id"] = r.file.test_id;
  j["timestamp"] = r.file.timestamp.empty() ? json(nullptr) : json(r.file.timestamp);
  j["kinematics"] = std::string(rotary::KinematicsName(res.kinematics));
  j["sphere_mm"] = setup.sphere_mm;
  j["location_errors"] = ErrorsJson(r);
  j["not_separable"] = SeparabilityJson(r, not_identifiable);
  j["not_identifiable"] = not_identifiable;
  j["rank"] = res.rank;
  j["parameters"] = rotary::kLocationErrorCount;
  j["condition"] = res.condition ? json(*res.condition) : json(nullptr);
  j["singular_values"] = res.singular_values;
  j["poses"] = res.poses;
  j["observations"] = res.observations;
  j["sigma_um"] = res.sigma_um;
  j["measured_rms_um"] = res.measured_rms_um;
  j["residual_rms_um"] = res.residual_rms_um;
  j["u_reading_um"] = r.file.u_reading_um ? json(*r.file.u_reading_um) : json(nullptr);
  j["iterations"] = res.iterations;
  j["converged"] = res.converged;
  j["residuals"] = PosesJson(r);
  j["warnings"] = r.warnings;
  return j;
}

}  // namespace km::usecases
