#include "usecases/dbb_report.h"

#include <cmath>

#include "analysis/dbb/dbb_uncertainty.h"
#include "usecases/dbb_json.h"
#include "usecases/uncertainty_json.h"

namespace km::usecases {
namespace {

// The ball bar's stated uncertainties (docs/formats.md §1.1; absent = 0, "not stated").
struct StatedDbb {
  dbb::DbbInputUncertainty u;
  std::vector<UncertaintyInput> inputs;
  bool any = false;
};

StatedDbb Stated(const dbb::DbbTest& t) {
  StatedDbb s;
  const char* units[] = {"µm", "µm", "°C"};
  double* values[] = {&s.u.reading_um, &s.u.bar_length_um, &s.u.bar_temperature_c};
  for (std::size_t i = 0; i < dbb::kDbbInputNames.size(); ++i) {
    const auto v = HeaderNumber(t.metadata, dbb::kDbbInputNames[i]);
    *values[i] = v.value_or(0.0);
    s.inputs.push_back({dbb::kDbbInputNames[i], v.value_or(0.0), units[i], v.has_value()});
    s.any = s.any || (v && *v > 0.0);
  }
  s.u.expansion_ppm_per_k = HeaderNumber(t.metadata, "bar_expansion_ppm_per_k").value_or(0.0);
  return s;
}

// The `uncertainty` object of outputs [first, first + keys) of a propagation.
nlohmann::json FiguresJson(const dbb::DbbUncertainty& r, std::size_t first,
                           const std::vector<std::string>& keys,
                           const std::vector<UncertaintyInput>& inputs) {
  uncertainty::McResult mc = r.mc;
  mc.outputs.assign(r.mc.outputs.begin() + static_cast<std::ptrdiff_t>(first),
                    r.mc.outputs.begin() + static_cast<std::ptrdiff_t>(first + keys.size()));
  std::vector<uncertainty::GumCheck> gum;
  for (std::size_t j = 0; j < keys.size() && first + j < r.gum.size(); ++j) {
    gum.push_back(r.gum[first + j]);
    gum.back().name = keys[j];
  }
  nlohmann::json j = UncertaintyJson(mc, inputs, keys, gum);
  for (std::size_t i = 0; i < gum.size(); ++i) {
    if (std::isnan(gum[i].u_gum)) j["figures"][keys[i]].erase("u_gum_um");
  }
  j["notes"] = r.notes;
  return j;
}

std::vector<std::string> Keys(const auto& list) {
  return std::vector<std::string>(list.begin(), list.end());
}

// tests[i].uncertainty and pairs[p].uncertainty: a pair's run gives its two tests' figures too
// (one bar: shared draws); a test outside a pair runs alone.
void AddUncertaintyOrThrow(nlohmann::json& out, const std::vector<dbb::DbbTest>& tests,
                           const dbb::DbbReport& report) {
  std::vector<bool> done(tests.size(), false);
  for (std::size_t p = 0; p < report.pairs.size() && p < out["pairs"].size(); ++p) {
    const auto& pr = report.pairs[p];
    const StatedDbb scw = Stated(tests[pr.cw]), sccw = Stated(tests[pr.ccw]);
    if (!scw.any && !sccw.any) continue;
    const auto r = dbb::PropagateDbbPair(tests[pr.cw], tests[pr.ccw], report.tests[pr.cw],
                                         report.tests[pr.ccw], pr, scw.u, sccw.u);
    out["tests"][pr.cw]["uncertainty"] =
        FiguresJson(r, 0, Keys(dbb::kDbbTestFigureKeys), scw.inputs);
    out["tests"][pr.ccw]["uncertainty"] =
        FiguresJson(r, 4, Keys(dbb::kDbbTestFigureKeys), sccw.inputs);
    // The pair's inputs: the readings of both files, the bar's (the larger where they differ).
    std::vector<UncertaintyInput> inputs = scw.inputs;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      inputs[i].u = std::max(inputs[i].u, sccw.inputs[i].u);
      inputs[i].stated = inputs[i].stated || sccw.inputs[i].stated;
    }
    out["pairs"][p]["uncertainty"] = FiguresJson(r, 8, Keys(dbb::kDbbPairFigureKeys), inputs);
    done[pr.cw] = done[pr.ccw] = true;
  }
  for (std::size_t i = 0; i < tests.size() && i < out["tests"].size(); ++i) {
    if (done[i]) continue;
    const StatedDbb s = Stated(tests[i]);
    out["tests"][i]["uncertainty"] =
        s.any ? FiguresJson(dbb::PropagateDbbTest(tests[i], report.tests[i], s.u), 0,
                            Keys(dbb::kDbbTestFigureKeys), s.inputs)
              : NoUncertaintyJson(s.inputs);
  }
  for (std::size_t p = 0; p < out["pairs"].size(); ++p) {
    if (!out["pairs"][p].contains("uncertainty")) {
      out["pairs"][p]["uncertainty"] = NoUncertaintyJson(Stated(tests[report.pairs[p].cw]).inputs);
    }
  }
}

// The propagation of every test and pair; when it cannot be made (inputs so large that a draw
// leaves the circle, e.g. values from an instrument register beyond what a file may state), each
// object says so instead of failing the analysis of the figures themselves.
void AddUncertainty(nlohmann::json& out, const std::vector<dbb::DbbTest>& tests,
                    const dbb::DbbReport& report) {
  try {
    AddUncertaintyOrThrow(out, tests, report);
  } catch (const std::exception& e) {
    const std::string why = std::string("not computed: ") + e.what();
    for (std::size_t i = 0; i < out["tests"].size() && i < tests.size(); ++i) {
      out["tests"][i]["uncertainty"] = NoUncertaintyJson(Stated(tests[i]).inputs);
      out["tests"][i]["uncertainty"]["method"] = why;
    }
    for (std::size_t p = 0; p < out["pairs"].size() && p < report.pairs.size(); ++p) {
      out["pairs"][p]["uncertainty"] = NoUncertaintyJson(Stated(tests[report.pairs[p].cw]).inputs);
      out["pairs"][p]["uncertainty"]["method"] = why;
    }
  }
}

// Keys beyond docs/formats.md §3.1 that make a stored result self-describing and reproducible.
void AddContext(nlohmann::json& j, const dbb::DbbTest& test, const dbb::CircularTestResult& r) {
  j["machine_id"] = test.machine_id;
  j["radius_mm"] = test.radius_mm;
  j["bar_length_mm"] = test.bar_length_mm;
  j["fitted_radius_mm"] = r.fitted_radius_mm;
  j["evaluated_turn_deg"] = {r.turn_start_deg, r.turn_end_deg};
  if (r.mean_radial_error_about_fixed_ball_um) {
    j["mean_radial_error_about_fixed_ball_um"] = *r.mean_radial_error_about_fixed_ball_um;
  }
  j["analysis_version"] = kDbbAnalysisVersion;
}

}  // namespace

nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests, const dbb::DbbReport& report) {
  nlohmann::json out = usecases::DbbReportToJson(report);
  for (std::size_t i = 0; i < tests.size() && i < out["tests"].size(); ++i) {
    AddContext(out["tests"][i], tests[i], report.tests[i].circular);
  }
  AddUncertainty(out, tests, report);
  return out;
}

nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests) {
  return DbbReportJson(tests, dbb::AnalyzeDbbSet(tests));
}

nlohmann::json DbbTestJson(const dbb::DbbTest& test) {
  return DbbReportJson({test})["tests"][0];
}

nlohmann::json DbbTraceJson(const dbb::DbbTest& test, const dbb::CircularTestResult& r) {
  nlohmann::json j;
  j["test_id"] = test.test_id;
  j["direction"] = dbb::ToString(test.direction);
  j["mode"] = dbb::ToString(r.mode);
  j["deviation_units"] = dbb::ToString(r.units);
  j["radius_mm"] = test.radius_mm;
  j["angle_deg"] = r.angle_deg;
  j["radial_error_um"] = r.radial_error_um;
  return j;
}

}  // namespace km::usecases
