#include "usecases/positioning_report.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "analysis/core/errors.h"

namespace km::usecases {
namespace {

using nlohmann::json;

json TargetsJson(const std::vector<positioning::TargetFigures>& targets) {
  json j = {{"target_mm", json::array()},
            {"mean_up_um", json::array()},
            {"mean_down_um", json::array()},
            {"s_up_um", json::array()},
            {"s_down_um", json::array()},
            {"reversal_um", json::array()},
            {"mean_bidirectional_um", json::array()},
            {"repeatability_um", json::array()}};
  for (const auto& t : targets) {
    j["target_mm"].push_back(t.target_mm);
    j["mean_up_um"].push_back(t.mean_up_um);
    j["mean_down_um"].push_back(t.mean_down_um);
    j["s_up_um"].push_back(t.s_up_um);
    j["s_down_um"].push_back(t.s_down_um);
    j["reversal_um"].push_back(t.reversal_um);
    j["mean_bidirectional_um"].push_back(t.mean_bidirectional_um);
    j["repeatability_um"].push_back(t.repeatability_um);
  }
  return j;
}

json AirJson(const positioning::AppliedCorrections& c) {
  json j = {{"applied", c.air_applied}, {"refractive_index", c.refractive_index}};
  if (!c.air_applied) {
    j["note"] = "the laser compensated the air itself (air_compensated: yes); n = 1 applied";
    return j;
  }
  j["air_temperature_c"] = c.air.temperature_c;
  j["air_pressure_pa"] = c.air.pressure_pa;
  j["air_humidity_pct"] = c.air.humidity_pct;
  j["laser_wavelength_nm"] = c.air.wavelength_nm;
  j["co2_ppm"] = 450;
  j["equation"] = "Edlén equation of Birch & Downs (1993, 1994), NIST form";
  j["end_of_axis_mm"] = c.end_of_axis_mm;
  j["correction_at_end_um"] = c.air_correction_at_end_um;
  return j;
}

json MaterialJson(const positioning::AppliedCorrections& c) {
  json j = {{"applied", c.material_applied}, {"reference_temperature_c", 20.0}};
  if (!c.material_applied) return j;
  j["material_temperature_c"] = c.material_temperature_c;
  j["expansion_ppm_per_k"] = c.expansion_ppm_per_k;
  j["end_of_axis_mm"] = c.end_of_axis_mm;
  j["correction_at_end_um"] = c.material_correction_at_end_um;
  return j;
}

json CompensationJson(const positioning::CompensationTable& t) {
  return {{"target_mm", t.target_mm},
          {"forward_um", t.forward_um},
          {"reverse_um", t.reverse_um},
          {"convention",
           "trim = -(mean unidirectional deviation); forward: motion towards larger "
           "coordinates"}};
}

json VdiJson(const positioning::Vdi3441Figures& v) {
  return {{"P_um", v.position_uncertainty_um},
          {"Ps_um", v.position_scatter_um},
          {"U_um", v.reversal_span_um},
          {"Pa_um", v.position_deviation_um},
          {"Ps_per_target_um", v.position_scatter_per_target_um},
          {"U_per_target_um", v.reversal_span_per_target_um}};
}

positioning::PositioningInputUncertainties InputUncertainties(
    const std::vector<UncertaintyInput>& inputs) {
  positioning::PositioningInputUncertainties u;
  double* const fields[] = {&u.laser_ppm,        &u.air_temperature_c,      &u.air_pressure_pa,
                            &u.air_humidity_pct, &u.material_temperature_c, &u.expansion_ppm_per_k};
  for (std::size_t i = 0; i < inputs.size() && i < positioning::kPositioningInputs; ++i) {
    *fields[i] = inputs[i].u;
  }
  return u;
}

// The Monte Carlo propagation of a file's stated input uncertainties through its figures, from
// the per-target figures of the readings as recorded (before any correction).
positioning::PositioningUncertainty PropagateFile(const ingest::PositioningFile& file,
                                                  const std::vector<UncertaintyInput>& inputs) {
  const auto raw = positioning::EvaluatePositioning(file.readings, file.file);
  return InFile(file.file, [&] {
    return positioning::PropagatePositioningUncertainty(raw.targets, file.corrections,
                                                        InputUncertainties(inputs));
  });
}

json UncertaintyOf(const PositioningReport& report) {
  if (!report.uncertainty) return NoUncertaintyJson(report.uncertainty_inputs);
  return UncertaintyJson(report.uncertainty->mc, report.uncertainty_inputs,
                         positioning::PositioningFigureKeys(), report.uncertainty->gum);
}

}  // namespace

std::vector<UncertaintyInput> PositioningUncertaintyInputs(const ingest::PositioningFile& file) {
  static const char* const kUnits[positioning::kPositioningInputs] = {"ppm", "°C", "Pa",
                                                                      "%",   "°C", "ppm/K"};
  const auto& names = positioning::PositioningInputNames();
  std::vector<UncertaintyInput> inputs;
  for (std::size_t i = 0; i < names.size(); ++i) {
    UncertaintyInput in{names[i], 0.0, kUnits[i], false};
    if (file.metadata.count(names[i])) {
      const auto v = HeaderNumber(file.metadata, names[i]);
      if (!v || *v < 0.0) {
        throw InvalidInput(file.file, 0, names[i],
                           "a standard uncertainty must be a finite number ≥ 0");
      }
      in.u = *v;
      in.stated = true;
    }
    inputs.push_back(std::move(in));
  }
  return inputs;
}

PositioningReport AnalyzePositioning(const ingest::PositioningFile& file) {
  PositioningReport r;
  r.file = file.file;
  r.machine_id = file.machine_id;
  r.axis = file.axis;
  r.cycle = file.cycle;
  r.timestamp = file.timestamp;
  r.readings = positioning::ApplyCorrections(file.readings, file.corrections, r.corrections);
  r.figures = positioning::EvaluatePositioning(r.readings, file.file);
  r.compensation = positioning::MakeCompensation(r.figures.targets);
  r.uncertainty_inputs = PositioningUncertaintyInputs(file);
  const bool stated = std::any_of(r.uncertainty_inputs.begin(), r.uncertainty_inputs.end(),
                                  [](const UncertaintyInput& in) { return in.stated; });
  if (stated) r.uncertainty = PropagateFile(file, r.uncertainty_inputs);
  return r;
}

json PositioningReportToJson(const PositioningReport& report) {
  const auto& f = report.figures;
  const auto& iso = f.iso;
  return {{"machine_id", report.machine_id},
          {"axis", report.axis},
          {"cycle", report.cycle},
          {"timestamp", report.timestamp},
          {"runs", f.runs},
          {"target_count", f.targets.size()},
          {"readings", f.readings},
          {"reversal_value_um", iso.reversal_value_um},
          {"mean_reversal_value_um", iso.mean_reversal_value_um},
          {"repeatability_up_um", iso.repeatability_up_um},
          {"repeatability_down_um", iso.repeatability_down_um},
          {"repeatability_um", iso.repeatability_um},
          {"systematic_deviation_up_um", iso.systematic_deviation_up_um},
          {"systematic_deviation_down_um", iso.systematic_deviation_down_um},
          {"systematic_deviation_um", iso.systematic_deviation_um},
          {"mean_deviation_range_um", iso.mean_deviation_range_um},
          {"accuracy_up_um", iso.accuracy_up_um},
          {"accuracy_down_um", iso.accuracy_down_um},
          {"accuracy_um", iso.accuracy_um},
          {"iso230_2_compliant", f.iso230_2_compliant},
          {"warnings", f.warnings},
          {"targets", TargetsJson(f.targets)},
          {"air", AirJson(report.corrections)},
          {"material", MaterialJson(report.corrections)},
          {"compensation", CompensationJson(report.compensation)},
          {"vdi3441", VdiJson(f.vdi)},
          {"uncertainty", UncertaintyOf(report)},
          {"analysis_version", kPositioningAnalysisVersion}};
}

json PositioningFilesToJson(const std::vector<PositioningReport>& reports) {
  if (reports.size() == 1) return PositioningReportToJson(reports.front());
  json files = json::array();
  for (const auto& r : reports) {
    json j = PositioningReportToJson(r);
    j["file"] = r.file;
    files.push_back(std::move(j));
  }
  return {{"files", std::move(files)}};
}

}  // namespace km::usecases
