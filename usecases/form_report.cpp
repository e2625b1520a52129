// JSON mapping of straightness, flatness and parallelism results (docs/formats.md §3).
#include "usecases/form_report.h"

#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <optional>
#include <span>

#include "analysis/core/errors.h"
#include "analysis/uncertainty/cross_check.h"
#include "analysis/uncertainty/monte_carlo.h"
#include "usecases/uncertainty_json.h"

namespace km::usecases {
namespace {

nlohmann::json Plane(const form::PlaneReport& p) {
  return {{"slope_x_um_per_m", p.slope_x_um_per_m},
          {"slope_y_um_per_m", p.slope_y_um_per_m},
          {"offset_um", p.offset_um}};
}

nlohmann::json Measurement(const ingest::StraightnessFile& f) {
  nlohmann::json m = {{"machine_id", f.machine_id},
                      {"axis", f.axis},
                      {"error_direction", f.error_direction},
                      {"sensor", f.sensor},
                      {"artefact", f.reference}};
  if (!f.reversal.empty()) {
    m["reversal"] = f.reversal;
    m["pair_id"] = f.pair_id;
    m["reversal_setup"] = f.reversal_setup;
  }
  return m;
}

// Where a file's set-up is stated: the reversal_setup line, else (default) the reversal line.
std::string SetupSource(const ingest::StraightnessFile& f) {
  if (f.reversal_setup_line > 0) return "line " + std::to_string(f.reversal_setup_line);
  return "reversal_setup absent, default";
}

// Both profiles of a pair must come from one set-up; the later file (input order) is named.
form::ReversalSetup PairSetup(const ingest::StraightnessFile& first,
                              const ingest::StraightnessFile& second) {
  if (first.reversal_setup != second.reversal_setup) {
    const std::size_t line =
        second.reversal_setup_line > 0 ? second.reversal_setup_line : second.reversal_line;
    throw InvalidInput(second.file, line, "reversal_setup",
                       "pair '" + second.pair_id + "' has set-up '" + second.reversal_setup +
                           "' here (" + SetupSource(second) + ") but '" + first.reversal_setup +
                           "' in " + first.file + " (" + SetupSource(first) +
                           "); both profiles of a pair must state the same set-up");
  }
  return InFile(second.file, [&] { return form::ParseReversalSetup(second.reversal_setup); });
}

// The uncertainty of a form result's figures from the file's u_reading_um (each reading on its
// own), by Monte Carlo through the same analysis (docs/methods.md §16.4): `figures` recomputes
// the figures from the readings plus one draw of reading errors. M = 1000 draws (the standard
// error of u within 3 % of u), seed 2304; the first-order GUM by central differences of every
// reading while they are at most 2000 (beyond, a note).
nlohmann::json FormUncertainty(
    const std::map<std::string, std::string>& metadata, std::size_t readings,
    const std::vector<std::string>& keys,
    const std::function<void(std::span<const double>, std::span<double>)>& figures) {
  const std::optional<double> u = HeaderNumber(metadata, "u_reading_um");
  const std::vector<UncertaintyInput> inputs{
      {"u_reading_um", u.value_or(0.0), "µm", u.has_value()}};
  if (!u || !(*u > 0.0)) return NoUncertaintyJson(inputs);
  const std::vector<uncertainty::McInput> mc_inputs{
      uncertainty::McInput::NormalGroup("u_reading_um", 0.0, *u, readings)};
  uncertainty::McOptions o;
  o.draws = 1000;
  o.seed = 2304;
  o.budget_draws = 0;  // one input: its contribution is u itself
  const uncertainty::McResult mc =
      uncertainty::PropagateMonteCarlo(figures, mc_inputs, keys.size(), o);
  uncertainty::McResult with_budget = mc;
  for (auto& out : with_budget.outputs) out.budget = {out.u};
  std::vector<uncertainty::GumCheck> gum;
  if (readings <= 2000) {
    std::vector<uncertainty::McInput> each;
    for (std::size_t k = 0; k < readings; ++k) {
      each.push_back(uncertainty::McInput::Normal("u_reading_um", 0.0, *u));
    }
    gum = uncertainty::CrossCheckGum(figures, each, mc, keys);
  }
  nlohmann::json j = UncertaintyJson(with_budget, inputs, keys, gum);
  j["notes"] = nlohmann::json::array({"u_reading_um: drawn independently for each of the " +
                                      std::to_string(readings) + " readings"});
  if (readings > 2000) {
    j["notes"].push_back("no first-order GUM check: more than 2000 readings");
  }
  return j;
}

}  // namespace

nlohmann::json FormResultToJson(const form::StraightnessResult& r) {
  nlohmann::json periodic = nlohmann::json::array();
  for (const auto& c : r.periodic) {
    periodic.push_back({{"period_mm", c.period_mm},
                        {"amplitude_um", c.amplitude_um},
                        {"phase_deg", c.phase_rad * 180.0 / std::numbers::pi},
                        {"false_alarm_probability", c.false_alarm_probability}});
  }
  return {{"straightness_lsq_um", r.straightness_lsq_um},
          {"straightness_min_zone_um", r.straightness_min_zone_um},
          {"straightness_end_point_um", r.straightness_end_point_um},
          {"slope_um_per_m", r.slope_um_per_m},
          {"periodic", periodic},
          {"reference", r.reference},
          {"references",
           {{"straightness_lsq_um", "least_squares_line"},
            {"straightness_min_zone_um", "minimum_zone_lines"},
            {"straightness_end_point_um", "end_point_line"},
            {"slope_um_per_m", "least_squares_line"},
            {"periodic", "least_squares_line_residual"}}},
          {"intercept_um", r.intercept_um},
          {"min_zone_slope_um_per_m", r.min_zone_slope_um_per_m},
          {"end_point_slope_um_per_m", r.end_point_slope_um_per_m},
          {"slope_with_periodic_um_per_m", r.slope_with_periodic_um_per_m},
          {"points", r.points},
          {"length_mm", r.length_mm}};
}

nlohmann::json FormResultToJson(const form::ReversalResult& r, const std::string& pair_id) {
  return {{"pair_id", pair_id},
          {"positions_mm", r.positions_mm},
          {"machine_um", r.machine_um},
          {"artefact_um", r.artefact_um},
          {"machine_straightness_lsq_um", r.machine_straightness_lsq_um},
          {"artefact_straightness_lsq_um", r.artefact_straightness_lsq_um},
          {"machine_slope_um_per_m", r.machine_slope_um_per_m},
          {"artefact_slope_um_per_m", r.artefact_slope_um_per_m},
          {"reference", "least_squares_line"},
          {"reversal_setup", form::ReversalSetupName(r.setup)},
          {"convention", r.convention}};
}

nlohmann::json FormResultToJson(const form::FlatnessResult& r) {
  return {{"flatness_lsq_um", r.flatness_lsq_um},
          {"flatness_min_zone_um", r.flatness_min_zone_um},
          {"range_um", r.range_um},
          {"plane", Plane(r.plane)},
          {"min_zone_plane", Plane(r.min_zone_plane)},
          {"reference", r.reference},
          {"references",
           {{"flatness_lsq_um", "least_squares_plane"},
            {"flatness_min_zone_um", "minimum_zone_planes"},
            {"range_um", r.range_reference},
            {"plane", "least_squares_plane"}}},
          {"points", r.points}};
}

nlohmann::json FormResultToJson(const form::ParallelismResult& r) {
  return {{"parallelism_um", r.parallelism_um},
          {"slope_um_per_m", r.slope_um_per_m},
          {"length_mm", r.length_mm},
          {"straightness_lsq_um", r.straightness_lsq_um},
          {"reference", r.reference},
          {"references",
           {{"parallelism_um", "datum"},
            {"slope_um_per_m", r.slope_reference},
            {"straightness_lsq_um", "least_squares_line"}}},
          {"points", r.points}};
}

nlohmann::json StraightnessFilesToJson(const std::vector<ingest::StraightnessFile>& files,
                                       const form::StraightnessOptions& options) {
  if (files.empty()) throw InvalidInput("", 0, "FILE", "no straightness file given");
  std::vector<nlohmann::json> profiles;
  for (const auto& f : files) {
    nlohmann::json j = InFile(
        f.file, [&] { return FormResultToJson(form::AnalyzeStraightness(f.profile, options)); });
    j["measurement"] = Measurement(f);
    form::Profile p = f.profile;
    form::StraightnessOptions figures_only;
    figures_only.find_periodic = false;
    j["uncertainty"] = InFile(f.file, [&] {
      return FormUncertainty(
          f.metadata, p.deviation_um.size(),
          {"straightness_lsq_um", "straightness_min_zone_um", "straightness_end_point_um"},
          [&](std::span<const double> e, std::span<double> y) {
            for (std::size_t k = 0; k < e.size(); ++k) {
              p.deviation_um[k] = f.profile.deviation_um[k] + e[k];
            }
            const auto r = form::AnalyzeStraightness(p, figures_only);
            y[0] = r.straightness_lsq_um;
            y[1] = r.straightness_min_zone_um;
            y[2] = r.straightness_end_point_um;
          });
    });
    profiles.push_back(std::move(j));
  }
  if (files.size() == 1) return profiles.front();

  // Reversal pairs: one `a` and one `b` with the same pair_id, in input order of first sight.
  std::vector<std::string> order;
  std::map<std::string, std::pair<int, int>> pairs;  // pair_id -> (index of a, index of b)
  for (std::size_t i = 0; i < files.size(); ++i) {
    const auto& f = files[i];
    if (f.reversal.empty()) continue;
    auto [it, fresh] = pairs.emplace(f.pair_id, std::make_pair(-1, -1));
    if (fresh) order.push_back(f.pair_id);
    int& slot = f.reversal == "a" ? it->second.first : it->second.second;
    if (slot >= 0) {
      throw InvalidInput(f.file, f.reversal_line, "reversal",
                         "pair '" + f.pair_id + "' already has a profile '" + f.reversal + "' (" +
                             files[static_cast<std::size_t>(slot)].file + ")");
    }
    slot = static_cast<int>(i);
  }
  nlohmann::json reversals = nlohmann::json::array();
  for (const auto& id : order) {
    const auto [ia, ib] = pairs.at(id);
    if (ia < 0 || ib < 0) continue;  // incomplete pair: the profile is reported on its own
    const auto& fa = files[static_cast<std::size_t>(ia)];
    const auto& fb = files[static_cast<std::size_t>(ib)];
    const form::ReversalSetup setup = ia < ib ? PairSetup(fa, fb) : PairSetup(fb, fa);
    const nlohmann::json rj = InFile(fb.file, [&] {
      return FormResultToJson(form::SeparateReversal(fa.profile, fb.profile, setup), id);
    });
    profiles[static_cast<std::size_t>(ia)]["reversal"] = rj;
    profiles[static_cast<std::size_t>(ib)]["reversal"] = rj;
    reversals.push_back(rj);
  }
  nlohmann::json out;
  out["profiles"] = nlohmann::json::array();
  for (std::size_t i = 0; i < files.size(); ++i) {
    nlohmann::json p = {{"file", files[i].file}};
    p.update(profiles[i]);
    out["profiles"].push_back(std::move(p));
  }
  out["reversals"] = reversals;
  if (reversals.size() == 1) out["reversal"] = reversals.front();
  return out;
}

nlohmann::json FlatnessFileToJson(const ingest::FlatnessFile& file) {
  nlohmann::json j =
      InFile(file.file, [&] { return FormResultToJson(form::AnalyzeFlatness(file.grid)); });
  j["measurement"] = {{"machine_id", file.machine_id}, {"datum", file.datum}};
  form::Grid g = file.grid;
  j["uncertainty"] = InFile(file.file, [&] {
    return FormUncertainty(file.metadata, g.z_um.size(),
                           {"flatness_lsq_um", "flatness_min_zone_um"},
                           [&](std::span<const double> e, std::span<double> y) {
                             for (std::size_t k = 0; k < e.size(); ++k) {
                               g.z_um[k] = file.grid.z_um[k] + e[k];
                             }
                             const auto r = form::AnalyzeFlatness(g);
                             y[0] = r.flatness_lsq_um;
                             y[1] = r.flatness_min_zone_um;
                           });
  });
  return j;
}

nlohmann::json ParallelismFileToJson(const ingest::ParallelismFile& file) {
  nlohmann::json j =
      InFile(file.file, [&] { return FormResultToJson(form::AnalyzeParallelism(file.profile)); });
  j["measurement"] = {{"machine_id", file.machine_id}, {"axis", file.axis}, {"datum", file.datum}};
  form::Profile p = file.profile;
  j["uncertainty"] = InFile(file.file, [&] {
    return FormUncertainty(file.metadata, p.deviation_um.size(),
                           {"parallelism_um", "straightness_lsq_um"},
                           [&](std::span<const double> e, std::span<double> y) {
                             for (std::size_t k = 0; k < e.size(); ++k) {
                               p.deviation_um[k] = file.profile.deviation_um[k] + e[k];
                             }
                             const auto r = form::AnalyzeParallelism(p);
                             y[0] = r.parallelism_um;
                             y[1] = r.straightness_lsq_um;
                           });
  });
  return j;
}

}  // namespace km::usecases
