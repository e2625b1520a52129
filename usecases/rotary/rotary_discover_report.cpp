#include "usecases/rotary/rotary_discover_report.h"

#include <cstdio>
#include <utility>

#include "analysis/core/errors.h"

namespace km::usecases {
namespace {

using nlohmann::json;
using rotary::RotaryEffect;

std::string Num(const char* format, double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

std::string EffectKey(RotaryEffect e) {
  switch (e) {
    case RotaryEffect::kCAngular:
      return "c_angular_positioning";
    case RotaryEffect::kTiltAngular:
      return "tilt_angular_positioning";
    case RotaryEffect::kCRadial:
      return "c_radial_error_motion";
    case RotaryEffect::kDrift:
      return "thermal_drift";
  }
  return {};
}

json ParameterJson(const rotary::EffectFit& f, rotary::Kinematics k, rotary::ParameterRange r) {
  json out = json::object();
  for (std::size_t j = r.first; j < r.first + r.count; ++j) {
    const bool d = f.determined[j];
    out[rotary::ParameterKey(k, j)] = {{"value", d ? json(f.value[j]) : json(nullptr)},
                                       {"sigma", d ? json(f.sigma[j]) : json(nullptr)},
                                       {"determined", d}};
  }
  return out;
}

json TrialJson(const rotary::RotaryDiscovery& d, const rotary::CandidateTrial& t) {
  return {{"effect", EffectKey(t.effect)},
          {"name", rotary::EffectName(d.kinematics, t.effect)},
          {"added_rank", t.added_rank},
          {"rms_after_um", t.rms_after_um},
          {"F", t.f},
          {"p_value", t.p_value},
          {"significant", t.significant},
          {"practical", t.practical}};
}

json StepsJson(const rotary::RotaryDiscovery& d) {
  json out = json::array();
  for (const auto& s : d.steps) {
    json trials = json::array();
    for (const auto& t : s.candidates) trials.push_back(TrialJson(d, t));
    out.push_back({{"named", s.named ? json(EffectKey(*s.named)) : json(nullptr)},
                   {"rms_before_um", s.rms_before_um},
                   {"rms_after_um", s.rms_after_um},
                   {"s_um", s.s_um},
                   {"candidates", trials}});
  }
  return out;
}

}  // namespace

RotaryDiscoveryReport DiscoverRotary(ingest::RotaryFile file) {
  RotaryDiscoveryReport r;
  try {
    r.result = rotary::DiscoverRotaryEffects(file.test, file.time_s, file.u_reading_um);
  } catch (const InvalidInput& e) {
    throw InvalidInput(file.file, e.line(), e.field(), e.reason());
  }
  r.file = std::move(file);
  return r;
}

std::vector<std::string> RotaryDiscoverySteps(const RotaryDiscoveryReport& r) {
  const auto& d = r.result;
  std::vector<std::string> out;
  for (std::size_t i = 0; i < d.steps.size(); ++i) {
    const auto& s = d.steps[i];
    const std::string gap = Num("gap %.3f", s.rms_before_um) + Num(" -> %.3f um", s.rms_after_um);
    if (i == 0) {
      out.push_back("step 0: the eight location errors: " + gap);
    } else if (s.named) {
      double f = 0.0, p = 1.0;
      for (const auto& t : s.candidates) {
        if (t.effect == *s.named) f = t.f, p = t.p_value;
      }
      out.push_back("step " + std::to_string(i) + ": " +
                    rotary::EffectName(d.kinematics, *s.named) + " named (F = " + Num("%.1f", f) +
                    (p < 1e-300 ? std::string(", p < 1e-300): ") : Num(", p = %.2g): ", p)) + gap);
    } else {
      out.push_back("step " + std::to_string(i) + ": no candidate passes");
    }
  }
  return out;
}

json RotaryDiscoveryToJson(const RotaryDiscoveryReport& r) {
  const auto& d = r.result;
  const auto k = d.kinematics;
  json named = json::array();
  for (RotaryEffect e : d.named) {
    named.push_back({{"effect", EffectKey(e)},
                     {"name", rotary::EffectName(k, e)},
                     {"parameters", ParameterJson(d.final_fit, k, rotary::EffectRange(e))}});
  }
  json j;
  j["analysis_version"] = kRotaryDiscoveryVersion;
  j["machine_id"] = r.file.machine_id;
  j["test_id"] = r.file.test_id;
  j["kinematics"] = std::string(rotary::KinematicsName(k));
  j["location_errors"] = ParameterJson(d.final_fit, k, {0, rotary::kLocationErrorCount});
  j["named"] = named;
  j["steps"] = StepsJson(d);
  j["step_sentences"] = RotaryDiscoverySteps(r);
  j["gap_rms_um"] = d.final_fit.rms_um;
  j["sigma_um"] = d.final_fit.s_um;
  j["u_reading_um"] = d.noise_um ? json(*d.noise_um) : json(nullptr);
  j["time_s_used"] = d.has_time;
  j["verdict"] = d.verdict;
  j["misfit"] = d.misfit.empty() ? json(nullptr) : json(d.misfit);
  return j;
}

}  // namespace km::usecases
