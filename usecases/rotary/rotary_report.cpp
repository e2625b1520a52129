#include "usecases/rotary/rotary_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "analysis/core/errors.h"
#include "analysis/rotary/rotary_uncertainty.h"
#include "usecases/uncertainty_json.h"

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

// The errors the poses do not determine, in words ("YOA, ZOA, BOA and COA"), empty when none.
std::string Undetermined(const RotaryReport& r) {
  const auto& names = rotary::LocationErrorNames(r.result.kinematics);
  std::vector<std::string> list;
  for (std::size_t i = 0; i < rotary::kLocationErrorCount; ++i) {
    if (!r.result.errors[i].identifiable) list.emplace_back(names[i]);
  }
  std::string out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    out += (i == 0 ? "" : i + 1 == list.size() ? " and " : ", ") + list[i];
  }
  return out;
}

// u_reading_um propagated through the identification (docs/methods.md §17.8): one figure per
// determined error, keyed as in location_errors; an angle error's u_um, U_um, interval_um and
// u_gum_um are in µrad, as its `unit` says.
json RotaryUncertaintyJson(const RotaryReport& r) {
  const auto& u = r.file.u_reading_um;
  const UncertaintyInput input{"u_reading_um", u.value_or(0.0), "µm", u.has_value()};
  json notes = json::array();
  const std::string undetermined = Undetermined(r);
  if (!undetermined.empty()) {
    notes.push_back(undetermined + (undetermined.find(' ') == std::string::npos ? " is" : " are") +
                    " not determined by these poses: no uncertainty is given for them");
  }
  if (!u || !(*u > 0.0)) {
    json j = NoUncertaintyJson({input});
    if (u) j["method"] = "none: u_reading_um is 0";
    if (!notes.empty()) j["notes"] = notes;
    return j;
  }
  const rotary::ReadingUncertainty p = rotary::PropagateReadingUncertainty(r.file.test, *u);
  std::vector<std::string> keys;
  std::vector<uncertainty::GumCheck> gum;
  for (std::size_t k = 0; k < p.errors.size(); ++k) {
    keys.push_back(LocationErrorKey(r.result.kinematics, p.errors[k]));
    uncertainty::GumCheck g;
    g.name = keys.back();
    g.u_gum = p.u_gum[k];
    g.u_mc = p.mc.outputs[k].u;
    if (g.u_mc > 0.0) g.relative_difference = std::abs(g.u_gum - g.u_mc) / g.u_mc;
    gum.push_back(g);  // differs stays false: the warning is written below, in the figure's unit
  }
  json j = UncertaintyJson(p.mc, {input}, keys, gum);
  // Beyond 5 %, and beyond three standard errors of the Monte Carlo u (1/√(2M) each): with
  // M = 500 a linear figure's two u differ by 3.2 % by chance alone (docs/methods.md §17.8).
  const double tolerance =
      std::max(0.05, 3.0 / std::sqrt(2.0 * double(std::max<std::size_t>(p.mc.draws, 1))));
  for (std::size_t k = 0; k < p.errors.size(); ++k) {
    const char* unit = rotary::IsAngularError(p.errors[k]) ? "µrad" : "µm";
    j["figures"][keys[k]]["unit"] = unit;
    if (gum[k].relative_difference <= tolerance) continue;
    char text[256];
    std::snprintf(text, sizeof text,
                  "%s: the first-order GUM gives u = %.4g %s, Monte Carlo %.4g %s (%.0f %% apart): "
                  "the identification is not linear in the readings here; the Monte Carlo value "
                  "is reported",
                  keys[k].c_str(), gum[k].u_gum, unit, gum[k].u_mc, unit,
                  100.0 * gum[k].relative_difference);
    j["warnings"].push_back(text);
  }
  notes.insert(notes.begin(),
               "each draw adds N(0, u_reading_um²) to each of dx, dy, dz of every pose and "
               "identifies the location errors again; the residual scatter of this test (sigma "
               "of location_errors) is what the errors describe, not an input");
  notes.insert(notes.begin() + 1,
               "an angle error's u_um, U_um, interval_um, u_gum_um and contribution_um are in "
               "µrad (its unit)");
  if (p.unconverged_draws > 0) {
    j["warnings"].push_back(std::to_string(p.unconverged_draws) +
                            " draws did not converge within the iteration limit");
  }
  j["notes"] = notes;
  return j;
}

}  // namespace

std::string LocationErrorKey(rotary::Kinematics k, std::size_t index) {
  return std::string(rotary::LocationErrorNames(k)[index]) +
         (rotary::IsAngularError(index) ? "_urad" : "_um");
}

RotaryReport AnalyzeRotary(ingest::RotaryFile file) {
  RotaryReport r;
  try {
    r.result = rotary::IdentifyLocationErrors(file.test);
  } catch (const InvalidInput& e) {
    throw InvalidInput(file.file, e.line(), e.field(), e.reason());
  }
  r.file = std::move(file);
  r.warnings = RotaryWarnings(r);
  r.uncertainty = RotaryUncertaintyJson(r);
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
  j["uncertainty"] = r.uncertainty;
  j["warnings"] = r.warnings;
  return j;
}

}  // namespace km::usecases
