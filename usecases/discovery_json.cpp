#include "usecases/discovery_json.h"

#include <cmath>

namespace km::usecases {
using nlohmann::json;

json KinematicJson(const hexapod::ParameterVector& k) {
  json strut = json::array(), base = json::array();
  for (int j = 0; j < 6; ++j) {
    strut.push_back(k[j]);
    base.push_back({k[6 + 3 * j], k[7 + 3 * j], k[8 + 3 * j]});
  }
  return {{"strut_offset_um", strut}, {"base_joint_offset_um", base}};
}

json EffectModelJson(const hexapod::ActiveEffect& a, const std::vector<double>& sigma,
                     const std::vector<bool>& at_bound) {
  json p = json::object(), u = json::object(), fixed = json::array(), bound = json::array();
  for (std::size_t i = 0; i < a.params.size(); ++i) {
    p[a.params[i].name] = a.params[i].value;
    // A parameter on its bound has no σ (null): it is held there, not estimated.
    const double sd = i < sigma.size() ? sigma[i] : 0.0;
    u[a.params[i].name] = std::isfinite(sd) ? json(sd) : json(nullptr);
    if (!a.params[i].free) fixed.push_back(a.params[i].name);
    if (i < at_bound.size() && at_bound[i]) bound.push_back(a.params[i].name);
  }
  json e = {{"effect", a.effect->Name()}, {"parameters", p}, {"uncertainty", u}};
  if (!fixed.empty()) e["fixed_parameters"] = fixed;
  if (!bound.empty()) e["at_bound"] = bound;
  // The headline value: the first parameter, with its unit.
  e["value"] = a.params.front().value;
  e["sigma"] = sigma.empty() || !std::isfinite(sigma.front()) ? json(nullptr) : json(sigma.front());
  e["unit"] = a.params.front().unit;
  return e;
}

namespace {

json TestGapsJson(const std::vector<TestGap>& gaps) {
  json list = json::array();
  for (const auto& g : gaps) {
    json row = {{"test_id", g.test_id},
                {"direction", dbb::ToString(g.direction)},
                {"gap_rms_before_um", g.gap_rms_before_um}};
    if (g.file) row["file"] = *g.file;
    if (g.gap_rms_after_um) row["gap_rms_after_um"] = *g.gap_rms_after_um;
    list.push_back(std::move(row));
  }
  return list;
}

json TracesJson(const TestTraces& t) {
  return {{"test_id", t.test_id},
          {"direction", dbb::ToString(t.direction)},
          {"angle_deg", t.angle_deg},
          {"measured_um", t.measured_um},
          {"model_before_um", t.model_before_um},
          {"model_after_um", t.model_after_um}};
}

// The compensation preview (analysis/hexapod/compensation.h) as JSON; null without one.
json CompensationPreviewJson(const std::optional<hexapod::CompensationPreview>& preview) {
  if (!preview) return nullptr;
  json tests = json::array();
  for (const auto& t : preview->tests) {
    tests.push_back({{"test_id", t.test_id},
                     {"direction", dbb::ToString(t.direction)},
                     {"circularity_measured_um", t.circularity_measured_um},
                     {"circularity_without_compensation_um", t.circularity_without_compensation_um},
                     {"predicted_circularity_with_compensation_um",
                      t.predicted_circularity_with_compensation_um}});
  }
  return {{"compensated_effects", preview->compensated_effects},
          {"basis", "calibrated machine: kinematic errors corrected, every modelled effect kept"},
          {"tests", tests}};
}

const hexapod::ActiveEffect* FindEffect(const hexapod::EffectFitResult& f, const std::string& n,
                                        std::vector<double>* sigma,
                                        std::vector<bool>* at_bound = nullptr) {
  for (std::size_t e = 0; e < f.effects.size(); ++e) {
    if (f.effects[e].effect->Name() != n) continue;
    if (sigma) *sigma = f.effect_sigma[e];
    if (at_bound && e < f.effect_at_bound.size()) *at_bound = f.effect_at_bound[e];
    return &f.effects[e];
  }
  return nullptr;
}

// What the σ of effect e of `f` covers: the statistical σ and every held input of the machine
// file propagated into it (analysis/hexapod/effect_fit.h, docs/methods.md §5).
void AddSigmaBudget(const hexapod::EffectFitResult& f, std::size_t e, json& entry) {
  json includes = json::array({"statistical"}), held = json::array();
  for (const auto& h : f.held_inputs) {
    const double shift =
        e < h.effect_shift.size() && !h.effect_shift[e].empty() ? h.effect_shift[e].front() : 0.0;
    if (shift == 0.0) continue;
    includes.push_back(h.name);
    held.push_back({{"input", h.name},
                    {"value", h.value},
                    {"u", h.u},
                    {"unit", h.unit},
                    {"contribution", std::abs(shift)}});
  }
  entry["sigma_includes"] = includes;
  if (held.empty()) return;
  const auto& st =
      e < f.effect_sigma_statistical.size() ? f.effect_sigma_statistical[e] : std::vector<double>{};
  entry["sigma_statistical"] =
      st.empty() || !std::isfinite(st.front()) ? json(nullptr) : json(st.front());
  entry["sigma_held_inputs"] = held;
}

}  // namespace

json HexapodDiscoveryJson(const ingest::MachineDefinition& machine,
                          const hexapod::EffectFitData& data,
                          const std::vector<hexapod::EffectFitResult>& history,
                          const discovery::EngineResult& r,
                          const HexapodDiscoveryFigures& figures) {
  json steps = json::array();
  for (std::size_t i = 0; i < r.steps.size(); ++i) {
    const auto& s = r.steps[i];
    const auto& after = history[i + 1];
    std::vector<double> sigma;
    std::vector<bool> at_bound;
    const auto* eff = FindEffect(after, s.added_effect, &sigma, &at_bound);
    json ev = {{"sentence", s.evidence.sentence},
               {"f_statistic", s.f_statistic},
               {"df_numerator", s.df_numerator},
               {"df_denominator", s.df_denominator},
               {"log10_p_value", s.log10_p_value},
               {"p_value", std::pow(10.0, s.log10_p_value)},
               {"rss_before_um2", s.rss_before_um2},
               {"rss_after_um2", s.rss_after_um2},
               {"cv_press_before_um2", s.press_before_um2},
               {"cv_press_after_um2", s.press_after_um2},
               {"variant", s.variant}};
    for (const auto& [k, v] : s.evidence.figures) ev[k] = v;
    if (eff) {
      const json entry = EffectModelJson(*eff, sigma, at_bound);
      ev["parameters"] = entry["parameters"];
      ev["uncertainty"] = entry["uncertainty"];
      if (entry.contains("at_bound")) ev["at_bound"] = entry["at_bound"];
    }
    json cands = json::array();
    for (const auto& c : s.candidates) {
      json cj = CandidateJson(c);
      cj["log10_p_white"] = c.log10_p_white;
      cj["log10_p_clustered"] = c.log10_p_clustered;
      cands.push_back(std::move(cj));
    }
    ev["candidates"] = cands;
    steps.push_back({{"added_effect", s.added_effect},
                     {"evidence", ev},
                     {"gap_rms_before_um", s.gap_rms_before_um},
                     {"gap_rms_after_um", s.gap_rms_after_um},
                     {"tests", TestGapsJson(figures.steps[i].tests)},
                     {"worst_test", TracesJson(figures.steps[i].worst_test)}});
  }
  const auto& fin = history.back();
  json model = json::array();
  json kin = {{"effect", "kinematic_parameters"},
              {"parameters", KinematicJson(fin.k_um)},
              {"uncertainty", KinematicJson(fin.k_sigma_um)},
              {"fixed_parameters", json::array()}};
  for (int i = 0; i < hexapod::kNumKinematicParameters; ++i)
    if (data.problem.fixed[static_cast<std::size_t>(i)])
      kin["fixed_parameters"].push_back(hexapod::ParameterName(i));
  model.push_back(kin);
  for (std::size_t e = 0; e < fin.effects.size(); ++e) {
    model.push_back(EffectModelJson(
        fin.effects[e], fin.effect_sigma[e],
        e < fin.effect_at_bound.size() ? fin.effect_at_bound[e] : std::vector<bool>{}));
    AddSigmaBudget(fin, e, model.back());
  }
  json last = json::array();
  for (const auto& c : r.last_candidates) {
    last.push_back({{"effect", c.effect},
                    {"variant", c.variant},
                    {"rejected_because", c.rejected_because},
                    {"log10_p_value", c.log10_p_value},
                    {"log10_p_white", c.log10_p_white},
                    {"log10_p_clustered", c.log10_p_clustered}});
  }
  return {{"kind", "hexapod"},
          {"machine_id", machine.machine_id},
          {"method", hexapod::ToString(data.problem.options.method)},
          {"base",
           {{"model", "kinematic_parameters"},
            {"gap_rms_um", history.front().residual_rms_um},
            {"tests", TestGapsJson(figures.base_tests)}}},
          {"steps", steps},
          {"final_model", model},
          {"unexplained_rms_um", r.unexplained_rms_um},
          {"noise_floor_um", r.noise_floor_um},
          {"repeatability_floor_um", r.repeatability_floor_um},
          {"verdict", discovery::ToString(r.verdict)},
          {"misfit", r.misfit.sentence.empty()
                         ? json(nullptr)
                         : json{{"sentence", r.misfit.sentence}, {"figures", r.misfit.figures}}},
          {"fit",
           {{"converged", fin.converged},
            {"stop_reason", fin.stop_reason},
            {"iterations", fin.iterations},
            {"uncertainty_clusters", fin.clusters}}},
          {"stop_reason", discovery::ToString(r.stop_reason)},
          {"stop_code", discovery::StopCode(r.stop_reason)},
          {"candidates_at_stop", last},
          {"final_tests", TestGapsJson(figures.final_tests)},
          {"condition_number", fin.condition_number},
          {"compensation", CompensationPreviewJson(figures.compensation)}};
}

nlohmann::json CandidateJson(const discovery::CandidateScore& c) {
  return {{"effect", c.effect},
          {"variant", c.variant},
          {"rss_after_um2", c.rss_after_um2},
          {"cv_press_um2", c.press_um2},
          {"log10_p_value", c.log10_p_value},
          {"qualified", c.rejected_because.empty()},
          {"rejected_because", c.rejected_because}};
}

}  // namespace km::usecases
