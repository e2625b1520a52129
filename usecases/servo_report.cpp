#include "usecases/servo_report.h"

#include <algorithm>
#include <cmath>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "usecases/dbb_report.h"

namespace km::usecases {
namespace {

using nlohmann::json;

json Number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json Array(const double* v, std::size_t n) {
  json a = json::array();
  for (std::size_t i = 0; i < n; ++i) a.push_back(Number(v[i]));
  return a;
}

json Vec3(const Eigen::Vector3d& v) {
  return Array(v.data(), 3);
}

bool Held(const servo::IdentifyResult& r, int p) {
  const std::string name = servo::LoadParamName(p);
  return std::any_of(r.fixed.begin(), r.fixed.end(),
                     [&](const servo::ParameterNote& n) { return n.parameter == name; });
}

// The identified keys with the values of `value(p)` (null for held parameters when `skip`).
json IdentifiedBlock(const servo::IdentifyResult& r, bool sigma) {
  using namespace servo;
  const auto pick = [&](int p, double v) {
    return sigma ? (Held(r, p) ? json(nullptr) : Number(r.sigma[p])) : Number(v);
  };
  const auto& m = r.identified;
  json j;
  j["platform_mass_kg"] = pick(kPlatformMass, m.platform_mass_kg);
  json cog = json::array();
  for (int k = 0; k < 3; ++k) {
    cog.push_back(sigma ? (Held(r, kCogDx + k) ? json(nullptr) : Number(r.platform_cog_sigma_mm[k]))
                        : Number(m.platform_cog_mm[k]));
  }
  j["platform_cog_mm"] = cog;
  j["strut_equivalent_mass_kg"] = pick(kStrutMass, m.strut_equivalent_mass_kg);
  j["motor_mass_kg"] = pick(kMotorMass, m.motor_mass_kg);
  json f0 = json::array();
  for (int i = 0; i < 6; ++i) f0.push_back(pick(kScrew1 + i, m.screw_friction_N[i]));
  j["screw_friction_N"] = f0;
  j["base_joint_torque_Nm"] = pick(kT0, m.base_joint_torque_Nm);
  j["base_joint_torque_per_N_m"] = pick(kT1, m.base_joint_torque_per_N_m);
  return j;
}

// The `joint_friction` effect with the identified parameters (docs/hexapod-effects.md).
json JointFrictionJson(const servo::IdentifyResult& r) {
  json j{{"torque_Nm", Number(r.identified.base_joint_torque_Nm)},
         {"torque_per_N_m", Number(r.identified.base_joint_torque_per_N_m)},
         {"ramp_mm", nullptr},
         {"ramp_sigma_mm", nullptr}};
  if (r.joint_ramp) {
    j["ramp_mm"] = Number(r.joint_ramp->ramp_mm);
    j["ramp_sigma_mm"] = Number(r.joint_ramp->sigma_mm);
    j["residual_rms_N"] = Number(r.joint_ramp->residual_rms_N);
    j["step_residual_rms_N"] = Number(r.joint_ramp->step_residual_rms_N);
  }
  return j;
}

}  // namespace

json ServoIdentifyJson(const std::string& machine_id, const std::vector<servo::ServoFile>& files,
                       const servo::IdentifyResult& r) {
  json j;
  j["machine_id"] = machine_id;
  j["files"] = json::array();
  for (const auto& f : files) j["files"].push_back(f.file);
  j["samples"] = r.samples;
  j["identified"] = IdentifiedBlock(r, false);
  j["uncertainty"] = IdentifiedBlock(r, true);
  j["residual_rms_N"] = Array(r.residual_rms_N.data(), 6);
  j["residual_sigma_N"] = Number(r.residual_sigma_N);
  j["rows_used"] = r.rows_used;
  j["condition_number"] = Number(r.condition_number);
  j["fixed"] = json::array();
  j["fixed_reasons"] = json::array();
  for (const auto& f : r.fixed) {
    j["fixed"].push_back(f.parameter);
    j["fixed_reasons"].push_back({{"parameter", f.parameter}, {"reason", f.reason}});
  }
  // Eq. 3.7 sees m_B (l2 + l3/2) + m_S l1 and m_B + m_J only in combination with m_S.
  j["held_design_values"] = {
      {{"parameter", "ball_screw_mass_kg"}, {"value", r.identified.ball_screw_mass_kg}},
      {{"parameter", "joint_mass_kg"}, {"value", r.identified.joint_mass_kg}}};
  j["iterations"] = r.iterations;
  j["joint_friction"] = JointFrictionJson(r);
  j["analysis_version"] = kServoAnalysisVersion;
  return j;
}

std::string MachineWithIdentified(const ingest::MachineDefinition& machine,
                                  const servo::IdentifyResult& r) {
  json doc = ingest::ParseJsonText(machine.source_json, "stored document");
  const json id = IdentifiedBlock(r, false);
  json& g = doc["gravity"];
  if (!g.is_object()) g = json::object();
  const auto& m = r.identified;
  if (!g.contains("g_mm_s2")) g["g_mm_s2"] = Vec3(1e3 * m.g_m_s2);
  for (const char* k :
       {"platform_mass_kg", "platform_cog_mm", "strut_equivalent_mass_kg", "motor_mass_kg"}) {
    g[k] = id[k];
  }
  json& f = doc["friction"];
  if (!f.is_object()) f = json::object();
  for (const char* k : {"screw_friction_N", "base_joint_torque_Nm", "base_joint_torque_per_N_m"}) {
    f[k] = id[k];
  }
  // The joint friction as a known effect of the model, so a DBB calibration cancels it
  // instead of fitting it ([Joint patent] formulas 15–20).
  if (r.joint_ramp) {
    const json jf = JointFrictionJson(r);
    json effect = {{"effect", "joint_friction"},
                   {"parameters",
                    {{"torque_Nm", jf["torque_Nm"]},
                     {"ramp_mm", std::clamp(r.joint_ramp->ramp_mm, 0.01, 50.0)},
                     {"torque_per_N_m", jf["torque_per_N_m"]}}}};
    json& effects = doc["effects"];
    if (!effects.is_array()) effects = json::array();
    bool replaced = false;
    for (auto& e : effects) {
      if (e.is_object() && e.value("effect", "") == "joint_friction") {
        e = effect;
        replaced = true;
      }
    }
    if (!replaced) effects.push_back(effect);
  }
  return doc.dump(2) + "\n";
}

json ServoForceJson(const std::string& machine_id, const servo::ServoFile& file,
                    const servo::ForceEstimate& f) {
  json j;
  j["machine_id"] = machine_id;
  j["file"] = file.file;
  j["test_id"] = file.test_id;
  j["t_s"] = f.t_s;
  json force = json::array(), sigma = json::array();
  for (std::size_t i = 0; i < f.force_N.size(); ++i) {
    force.push_back(Vec3(f.force_N[i]));
    sigma.push_back(Vec3(f.sigma_N[i]));
  }
  j["force_N"] = std::move(force);
  j["sigma_N"] = std::move(sigma);
  json measured = json::array(), model = json::array();
  for (std::size_t i = 0; i < f.strut_model_N.size(); ++i) {
    measured.push_back(Array(file.samples[i].force_N.data(), 6));
    model.push_back(Array(f.strut_model_N[i].data(), 6));
  }
  j["strut_force_N"] = std::move(measured);
  j["strut_model_N"] = std::move(model);
  j["mean_force_N"] = Vec3(f.mean_force_N);
  j["mean_sigma_N"] = Vec3(f.mean_sigma_N);
  j["strut_noise_N"] = Array(f.strut_noise_N.data(), 6);
  j["joint_ramp_mm"] = Number(f.joint_ramp_mm);
  j["screw_ramp_mm"] = Number(f.screw_ramp_mm);
  j["ramps_from"] = {{"joint", f.joint_ramp_estimated ? "record" : "machine model"},
                     {"screw", f.screw_ramp_estimated ? "record" : "given"}};
  j["analysis_version"] = kServoAnalysisVersion;
  return j;
}

servo::ForceOptions ForceOptionsOf(const ingest::MachineDefinition& machine) {
  servo::ForceOptions o;
  for (const auto& e : machine.effects) {
    if (e.effect != "joint_friction") continue;
    for (const auto& [name, value] : e.parameters) {
      if (name == "ramp_mm" && value >= 0.0 && value <= 100.0) o.joint_ramp_mm = value;
    }
  }
  return o;
}

json ServoJointsJson(const std::string& machine_id, const servo::JointsResult& r,
                     const servo::JointOptions& o) {
  json j;
  j["machine_id"] = machine_id;
  j["legs"] = json::array();
  for (const auto& l : r.legs) {
    json leg{{"leg", l.leg},
             {"resistance_Nm", Number(l.resistance_Nm)},
             {"sigma_Nm", Number(l.sigma_Nm)},
             {"level", l.level},
             {"evidence", l.evidence},
             {"reference_Nm", Number(l.reference_Nm)},
             {"ratio", Number(l.ratio)},
             {"previous_Nm", l.previous_Nm ? Number(*l.previous_Nm) : json(nullptr)},
             {"screw_friction_N", Number(l.screw_friction_N)},
             {"screw_friction_sigma_N", Number(l.screw_friction_sigma_N)}};
    leg["joints"] = json::array();
    for (const auto& jv : l.joints) {
      leg["joints"].push_back(
          {{"joint", jv.joint},
           {"resistance_Nm", jv.identified ? Number(jv.resistance_Nm) : json(nullptr)},
           {"sigma_Nm", jv.identified ? Number(jv.sigma_Nm) : json(nullptr)},
           {"identified", jv.identified}});
    }
    j["legs"].push_back(std::move(leg));
  }
  j["level"] = r.level;
  j["reference_source"] = r.reference_source;
  j["limits"] = {{"level2_ratio", o.level2_ratio},
                 {"level3_ratio", o.level3_ratio},
                 {"increase_warn", o.increase_warn},
                 {"increase_stop", o.increase_stop}};
  j["pairs"] = r.pairs;
  j["rows"] = r.rows;
  j["residual_rms_N"] = Number(r.residual_rms_N);
  j["condition_number"] = Number(r.condition_number);
  j["not_identifiable"] = r.not_identifiable;
  j["analysis_version"] = kServoAnalysisVersion;
  return j;
}

std::array<double, 6> PreviousResistances(const std::string& text, const std::string& file) {
  json doc;
  doc = ingest::ParseJsonText(text, file);
  if (!doc.is_object() || !doc.contains("legs") || !doc["legs"].is_array()) {
    throw InvalidInput(file, 0, "legs", "a `servo joints` result with legs[] is needed");
  }
  std::array<double, 6> out{};
  std::array<bool, 6> seen{};
  for (const auto& leg : doc["legs"]) {
    if (!leg.is_object() || !leg.contains("leg") || !leg["leg"].is_number_integer() ||
        !leg.contains("resistance_Nm") || !leg["resistance_Nm"].is_number()) {
      throw InvalidInput(file, 0, "legs", "each leg needs `leg` (1–6) and `resistance_Nm`");
    }
    const auto k = leg["leg"].get<long>();
    const double v = leg["resistance_Nm"].get<double>();
    if (k < 1 || k > 6) throw InvalidInput(file, 0, "legs[].leg", "must be 1 … 6");
    if (!(v > 0.0 && v < 1e6)) {
      throw InvalidInput(file, 0, "legs[].resistance_Nm", "must be positive and below 1e6");
    }
    out[static_cast<std::size_t>(k - 1)] = v;
    seen[static_cast<std::size_t>(k - 1)] = true;
  }
  for (int k = 0; k < 6; ++k) {
    if (!seen[k])
      throw InvalidInput(file, 0, "legs", "leg " + std::to_string(k + 1) + " is missing");
  }
  return out;
}

namespace {

json FeedDriveAxisJson(const servo::FeedDriveResult& r) {
  json j{{"axis", r.axis},
         {"samples", r.samples},
         {"steady_samples", r.steady_samples},
         {"reversals", r.reversals},
         {"coulomb_N", Number(r.coulomb_N)},
         {"coulomb_sigma_N", Number(r.coulomb_sigma_N)},
         {"viscous_N_s_per_mm", Number(r.viscous_N_s_per_mm)},
         {"viscous_sigma_N_s_per_mm", Number(r.viscous_sigma_N_s_per_mm)},
         {"offset_N", Number(r.offset_N)},
         {"slope_N_per_mm", Number(r.slope_N_per_mm)},
         {"moving_mass_kg", Number(r.moving_mass_kg)},
         {"residual_rms_N", Number(r.residual_rms_N)}};
  j["ripple"] = json::array();
  for (const auto& p : r.ripple) {
    j["ripple"].push_back({{"period_mm", Number(p.period_mm)},
                           {"period_sigma_mm", Number(p.period_sigma_mm)},
                           {"amplitude_N", Number(p.amplitude_N)},
                           {"amplitude_sigma_N", Number(p.amplitude_sigma_N)},
                           {"phase_deg", Number(p.phase_deg)}});
  }
  const auto lugre = [](const servo::LugreParameters& p) {
    return json{{"Fc_N", Number(p.Fc_N)},
                {"Fs_N", Number(p.Fs_N)},
                {"vs_mm_s", Number(p.vs_mm_s)},
                {"sigma0_N_per_um", Number(p.sigma0_N_per_um)},
                {"sigma1_N_s_per_mm", Number(p.sigma1_N_s_per_mm)},
                {"sigma2_N_s_per_mm", Number(p.sigma2_N_s_per_mm)}};
  };
  j["lugre"] = r.lugre ? lugre(*r.lugre) : json(nullptr);
  j["lugre_sigma"] = r.lugre_sigma ? lugre(*r.lugre_sigma) : json(nullptr);
  if (r.lugre && r.lugre_sigma) {  // the Stribeck rise's form and exponent δ (σ 0 when held)
    const bool lorentzian = r.lugre->stribeck_form == servo::LugreParameters::Form::kLorentzian;
    j["lugre"]["stribeck_form"] = lorentzian ? "lorentzian" : "exponential";
    j["lugre"]["stribeck_exponent"] = Number(r.lugre->stribeck_exponent);
    j["lugre_sigma"]["stribeck_exponent"] = Number(r.lugre_sigma->stribeck_exponent);
    j["lugre_form_delta_chi2"] = Number(r.lugre_form_delta_chi2);
    j["lugre_forms_comparable"] = r.lugre_forms_comparable;
  }
  j["lugre_identifiable"] = nullptr;
  if (r.lugre) {  // a parameter the records do not determine: null value and σ
    const auto& f = r.lugre_identifiable;
    const std::pair<const char*, bool> flags[] = {{"Fc_N", f.Fc_N},
                                                  {"Fs_N", f.Fs_N},
                                                  {"vs_mm_s", f.vs_mm_s},
                                                  {"sigma0_N_per_um", f.sigma0_N_per_um},
                                                  {"sigma1_N_s_per_mm", f.sigma1_N_s_per_mm},
                                                  {"sigma2_N_s_per_mm", f.sigma2_N_s_per_mm}};
    for (const auto& [key, ok] : flags) {
      j["lugre_identifiable"][key] = ok;
      if (!ok) j["lugre"][key] = j["lugre_sigma"][key] = nullptr;
    }
  }
  j["lugre_residual_rms_N"] = r.lugre ? Number(r.lugre_residual_rms_N) : json(nullptr);
  if (!r.lugre_note.empty()) j["lugre_note"] = r.lugre_note;
  j["stick_motion_um"] = r.stick_motion_um ? Number(*r.stick_motion_um) : json(nullptr);
  return j;
}

}  // namespace

json ServoFeedDriveJson(const std::string& machine_id,
                        const std::vector<servo::FeedDriveResult>& axes) {
  json j;
  j["machine_id"] = machine_id;
  j["axes"] = json::array();
  for (const auto& a : axes) j["axes"].push_back(FeedDriveAxisJson(a));
  if (!axes.empty()) {
    for (const auto& [k, v] : j["axes"][0].items()) j[k] = v;
  }
  j["analysis_version"] = kServoAnalysisVersion;
  return j;
}

json DbbStickComparisonJson(const std::vector<dbb::DbbTest>& tests,
                            const std::vector<std::string>& names,
                            const servo::FeedDriveResult& drive, std::optional<double> kp_per_s) {
  json out = json::array();
  for (std::size_t i = 0; i < tests.size(); ++i) {
    const auto& t = tests[i];
    const json analysed = DbbTestJson(t);
    json measured = json::array();
    for (const auto& d : analysed.value("diagnosis", json::array())) {
      const std::string effect = d.value("effect", "");
      if (effect.rfind("reversal_spike", 0) == 0 || effect == "stick_slip") {
        measured.push_back({{"effect", effect},
                            {"value", d.value("value", json(nullptr))},
                            {"uncertainty", d.value("uncertainty", json(nullptr))},
                            {"unit", d.value("unit", json(nullptr))}});
      }
    }
    json predicted = nullptr;
    if (drive.lugre && drive.lugre_identifiable.Fc_N && drive.lugre_identifiable.sigma0_N_per_um &&
        kp_per_s && t.radius_mm > 0.0 && t.feed_mm_min > 0.0) {
      predicted = Number(servo::StickMotionUm(*drive.lugre, t.radius_mm, t.feed_mm_min, *kp_per_s));
    }
    out.push_back({{"file", i < names.size() ? names[i] : t.test_id},
                   {"test_id", t.test_id},
                   {"direction", dbb::ToString(t.direction)},
                   {"radius_mm", t.radius_mm},
                   {"feed_mm_min", t.feed_mm_min},
                   {"measured", measured},
                   {"predicted_stick_motion_um", predicted}});
  }
  return out;
}

json ServoSummaryJson(const servo::ServoFile& f) {
  json j;
  j["record"] = f.hexapod ? "hexapod" : "feed_drive";
  j["samples"] = f.t_s.size();
  j["duration_s"] = f.t_s.empty() ? 0.0 : f.t_s.back() - f.t_s.front();
  j["test_id"] = f.test_id;
  j["motion"] = f.motion;
  j["direction"] = f.direction.empty() ? json(nullptr) : json(f.direction);
  const auto stats = [](const std::vector<double>& v, json& out) {
    double lo = INFINITY, hi = -INFINITY, ss = 0.0;
    for (double x : v) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
      ss += x * x;
    }
    out["force_min_N"] = Number(lo);
    out["force_max_N"] = Number(hi);
    out["force_rms_N"] = Number(v.empty() ? NAN : std::sqrt(ss / static_cast<double>(v.size())));
  };
  if (f.hexapod) {
    json lo = json::array(), hi = json::array(), rms = json::array();
    for (int s = 0; s < 6; ++s) {
      std::vector<double> v;
      for (const auto& x : f.samples) v.push_back(x.force_N[s]);
      json one;
      stats(v, one);
      lo.push_back(one["force_min_N"]);
      hi.push_back(one["force_max_N"]);
      rms.push_back(one["force_rms_N"]);
    }
    j["tool_length_mm"] = f.tool_length_mm;
    j["force_min_N"] = lo;
    j["force_max_N"] = hi;
    j["force_rms_N"] = rms;
  } else {
    j["axes"] = json::array();
    for (const auto& a : f.axes) {
      json one{{"axis", a.axis}};
      const auto [mn, mx] = std::minmax_element(a.pos_mm.begin(), a.pos_mm.end());
      one["stroke_mm"] = Number(a.pos_mm.empty() ? NAN : *mx - *mn);
      stats(a.force_N, one);
      j["axes"].push_back(std::move(one));
    }
  }
  j["analysis_version"] = kServoAnalysisVersion;
  return j;
}

}  // namespace km::usecases
