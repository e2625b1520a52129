#include "usecases/discovery_report.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/discovery/hexapod_family.h"
#include "analysis/discovery/serial_family.h"
#include "analysis/hexapod/dbb_geometry.h"
#include "analysis/serial_effects/registry.h"
#include "ingest/iso8601.h"
#include "usecases/discovery_json.h"
#include "usecases/effect_calibration.h"
#include "usecases/updated_machine.h"

namespace km::usecases {
namespace {

using nlohmann::json;

// Serial machines: at most this many effects are added (of the 13 linear form effects).
constexpr int kSerialMaxSteps = 12;

// The machine's stored effects resolved against this test set (unknown names refused; the
// parameters of tools not used here are left at their defaults).
std::vector<hexapod::ActiveEffect> KnownEffects(const ingest::MachineDefinition& m,
                                                const hexapod::EffectSetup& setup) {
  std::vector<hexapod::ActiveEffect> out;
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    const auto& me = m.effects[i];
    const auto* e = hexapod::FindHexapodEffect(me.effect);
    const std::string field = "effects[" + std::to_string(i) + "].effect";
    if (!e) {
      throw InvalidInput(
          m.machine_id, 0, field,
          "'" + me.effect + "' is not a hexapod effect (" + hexapod::HexapodEffectNames() + ")");
    }
    hexapod::ActiveEffect a{e, e->Parameters(setup)};
    if (a.params.empty()) {
      throw InvalidInput(m.machine_id, 0, field,
                         me.effect +
                             " cannot be evaluated for these tests (missing masses, "
                             "timestamps or temperatures)");
    }
    for (const auto& [name, value] : me.parameters)
      for (auto& p : a.params)
        if (p.name == name) p.value = std::clamp(value, p.lower, p.upper);
    out.push_back(std::move(a));
  }
  return out;
}

DiscoveryOutcome HexapodDiscovery(const DiscoveryStudy& study, const ProgressFn& progress) {
  const ingest::MachineDefinition& machine = *study.machine;
  bool absolute = true;
  for (const auto& t : study.tests) absolute = absolute && t.fixed_ball_mm.has_value();
  const auto method = absolute ? hexapod::CalibrationMethod::kAbsolute
                               : hexapod::CalibrationMethod::kCentreCorrected;
  const hexapod::EffectFitData data =
      PrepareNamedEffectFit(machine, study.tests, study.names, method, study.max_samples_per_test);
  discovery::HexapodFamily family(data, KnownEffects(machine, data.prepared.setup));
  const auto r = discovery::RunDiscovery(family, discovery::HexapodEngineOptions(), progress);
  DiscoveryOutcome out;
  const auto figures = ComputeHexapodDiscoveryFigures(data, family.History(), r, study.names);
  out.report = HexapodDiscoveryJson(machine, data, family.History(), r, figures);
  out.updated_machine = UpdatedMachine(machine, family.History().back());
  if (progress) progress(1.0, "done");
  return out;
}

json NumberOrArray(const std::vector<double>& v) {
  if (v.size() == 1) return v[0];
  return json(v);
}

const discovery::SerialEffectFit* FindSerialEffect(const discovery::SerialModel& m,
                                                   const std::string& name) {
  for (const auto& e : m.effects)
    if (e.name == name) return &e;
  return nullptr;
}

// `kinemetric discover` JSON of the serial family (docs/formats.md §3): the steps with their
// evidence, the final model (set-up terms first), the verdict of the engine.
json SerialDiscoveryJson(const discovery::SerialFamily& family, const discovery::EngineResult& r) {
  const auto& history = family.History();
  const auto& notes = family.Notes();
  json steps = json::array();
  for (std::size_t i = 0; i < r.steps.size(); ++i) {
    const auto& s = r.steps[i];
    json ev = {{"sentence", s.evidence.sentence},
               {"variant", s.variant},
               {"rss_before_um2", s.rss_before_um2},
               {"rss_after_um2", s.rss_after_um2},
               {"f_statistic", s.f_statistic},
               {"df_numerator", s.df_numerator},
               {"df_denominator", s.df_denominator},
               {"log10_p_value", s.log10_p_value},
               {"p_value", std::pow(10.0, s.log10_p_value)},
               {"cv_press_before_um2", s.press_before_um2},
               {"cv_press_after_um2", s.press_after_um2}};
    for (const auto& [k, v] : s.evidence.figures) ev[k] = v;
    if (const auto* e =
            i + 1 < history.size() ? FindSerialEffect(history[i + 1], s.added_effect) : nullptr) {
      ev["value"] = NumberOrArray(e->value);
      ev["sigma"] = NumberOrArray(e->sigma);
      ev["unit"] = e->unit;
      ev["z_score"] = e->z_score;
      ev["parameters"] = e->parameters;
    }
    // Runner-up: the best other identifiable effect (any variant) at this step.
    const discovery::CandidateScore* runner = nullptr;
    json cands = json::array();
    for (const auto& c : s.candidates) {
      cands.push_back(CandidateJson(c));
      if (c.effect == s.added_effect || !c.identifiable) continue;
      if (!runner || c.rss_after_um2 < runner->rss_after_um2) runner = &c;
    }
    ev["runner_up"] = runner ? json(runner->effect) : json(nullptr);
    ev["runner_up_rss_drop_um2"] =
        runner ? std::max(0.0, s.rss_before_um2 - runner->rss_after_um2) : 0.0;
    ev["indistinguishable_from"] =
        i < notes.size() ? notes[i].indistinguishable_from : std::vector<std::string>{};
    ev["candidates"] = cands;
    steps.push_back({{"added_effect", s.added_effect},
                     {"evidence", ev},
                     {"gap_rms_before_um", s.gap_rms_before_um},
                     {"gap_rms_after_um", s.gap_rms_after_um}});
  }
  const auto& fin = history.back();
  const std::string um = serial_effects::Info(serial_effects::EffectId::kCentreOffset).unit;
  json model = json::array();
  model.push_back({{"effect", family.Name(serial_effects::EffectId::kCentreOffset)},
                   {"value", {fin.centre_um[0], fin.centre_um[1]}},
                   {"unit", um},
                   {"sigma", {fin.centre_sigma_um[0], fin.centre_sigma_um[1]}}});
  model.push_back({{"effect", family.Name(serial_effects::EffectId::kRadiusError)},
                   {"value", fin.radius_um},
                   {"unit", serial_effects::Info(serial_effects::EffectId::kRadiusError).unit},
                   {"sigma", fin.radius_sigma_um}});
  for (const auto& e : fin.effects) {
    json x = {{"effect", e.name},
              {"value", NumberOrArray(e.value)},
              {"unit", e.unit},
              {"sigma", NumberOrArray(e.sigma)},
              {"z_score", e.z_score}};
    if (!e.shape_map.empty()) x["shape"] = e.shape_map;
    if (e.at_bound) x["at_physical_bound"] = true;
    model.push_back(x);
  }
  // At the stop: the best candidates that failed, with the rule, and those the model absorbs.
  std::vector<const discovery::CandidateScore*> failed;
  json last = json::array(), not_identifiable = json::array(), rejected = json::array();
  for (const auto& c : r.last_candidates) {
    last.push_back({{"effect", c.effect},
                    {"variant", c.variant},
                    {"rejected_because", c.rejected_because},
                    {"log10_p_value", c.log10_p_value}});
    if (!c.identifiable) {
      if (std::find(not_identifiable.begin(), not_identifiable.end(), c.effect) ==
          not_identifiable.end())
        not_identifiable.push_back(c.effect);
    } else if (!c.rejected_because.empty()) {
      failed.push_back(&c);
    }
  }
  std::sort(failed.begin(), failed.end(),
            [](const auto* a, const auto* b) { return a->rss_after_um2 < b->rss_after_um2; });
  for (std::size_t k = 0; k < failed.size() && k < 3; ++k) {
    const auto& c = *failed[k];
    rejected.push_back(c.effect + (c.variant.empty() ? "" : " (" + c.variant + ")") + ": " +
                       c.rejected_because);
  }
  const auto& base = history.front().residual;
  const double base_rms =
      base.size() ? std::sqrt(base.squaredNorm() / static_cast<double>(base.size())) : 0.0;
  return {{"kind", "serial"},
          {"plane", dbb::ToString(family.Plane())},
          {"base", {{"model", "setup_terms"}, {"gap_rms_um", base_rms}}},
          {"held_out", family.SplitIntoSubTraces() ? "interleaved samples" : "tests"},
          {"steps", steps},
          {"final_model", model},
          {"unexplained_rms_um", r.unexplained_rms_um},
          {"noise_floor_um", r.noise_floor_um},
          {"verdict", discovery::ToString(r.verdict)},
          {"stop_reason", discovery::ToString(r.stop_reason)},
          {"stop_code", discovery::StopCode(r.stop_reason)},
          {"rejected", rejected},
          {"not_identifiable", not_identifiable},
          {"candidates_at_stop", last}};
}

DiscoveryOutcome SerialDiscovery(const DiscoveryStudy& study, const ProgressFn& progress) {
  if (study.tests.empty()) throw InvalidInput("", 0, "FILE", "no DBB test given");
  std::vector<dbb::DiagnosisTrace> traces;
  std::vector<std::string> test_ids;
  for (std::size_t k = 0; k < study.tests.size(); ++k) {
    const dbb::DbbTest& t = study.tests[k];
    const std::string name = k < study.names.size() ? study.names[k] : t.test_id;
    try {
      traces.push_back(dbb::MakeDiagnosisTrace(t, dbb::AnalyzeCircularTest(t)));
    } catch (const InvalidInput& e) {
      throw InvalidInput(name, e.line(), e.field(), e.reason());
    }
    test_ids.push_back(t.test_id);
    if (t.plane != study.tests.front().plane) {
      throw InvalidInput(name, 0, "plane",
                         std::string("all files must be in one plane (") +
                             dbb::ToString(study.tests.front().plane) + " in " +
                             (study.names.empty() ? study.tests.front().test_id : study.names[0]) +
                             ")");
    }
  }
  discovery::EngineOptions options;
  options.max_steps = kSerialMaxSteps;
  const auto run =
      discovery::DiscoverSerial(traces, test_ids, study.tests.front().plane, {}, options, progress);
  DiscoveryOutcome out;
  out.report = SerialDiscoveryJson(*run.family, run.result);
  out.report["alternatives_tried"] = run.alternatives_tried;
  out.report["alternative"] = run.alternative.empty() ? json(nullptr) : json(run.alternative);
  return out;
}

}  // namespace

DiscoveryOutcome RunDiscoveryStudy(const DiscoveryStudy& study, const ProgressFn& progress) {
  if (study.tests.empty()) throw InvalidInput("", 0, "FILE", "no DBB test given");
  if (study.machine && study.machine->kind == "hexapod") return HexapodDiscovery(study, progress);
  DiscoveryOutcome out = SerialDiscovery(study, progress);
  if (progress) progress(1.0, "done");
  return out;
}

}  // namespace km::usecases
