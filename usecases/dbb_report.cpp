#include "usecases/dbb_report.h"

#include "usecases/dbb_json.h"

namespace km::usecases {
namespace {

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
