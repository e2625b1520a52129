#include "server/report.h"

namespace km::server {

nlohmann::json DbbTestJson(const dbb::DbbTest& test, const dbb::CircularTestResult& r) {
  nlohmann::json j;
  j["test_id"] = r.test_id;
  j["machine_id"] = test.machine_id;
  j["direction"] = dbb::ToString(r.direction);
  j["plane"] = dbb::ToString(test.plane);
  j["mode"] = dbb::ToString(r.mode);
  j["centre_offset_um"] = {r.centre_offset_um[0], r.centre_offset_um[1]};
  j["average_radial_error_um"] = r.average_radial_error_um;
  j["circularity_um"] = r.circularity_um;
  j["fitted_radius_mm"] = r.fitted_radius_mm;
  j["fit_rms_um"] = r.fit_rms_um;
  j["radius_mm"] = test.radius_mm;
  j["bar_length_mm"] = test.bar_length_mm;
  j["sample_count"] = r.sample_count;
  j["evaluated_turn_deg"] = {r.turn_start_deg, r.turn_end_deg};
  if (r.radial_error_range_um) j["radial_error_range_um"] = *r.radial_error_range_um;
  if (r.mean_radial_error_about_fixed_ball_um) {
    j["mean_radial_error_about_fixed_ball_um"] = *r.mean_radial_error_about_fixed_ball_um;
  }
  if (r.machine_centre_error_um) {
    j["machine_centre_error_um"] = {(*r.machine_centre_error_um)[0],
                                    (*r.machine_centre_error_um)[1]};
  }
  j["analysis_version"] = kDbbAnalysisVersion;
  return j;
}

nlohmann::json DbbReportJson(const std::vector<dbb::DbbTest>& tests) {
  nlohmann::json out;
  out["tests"] = nlohmann::json::array();
  for (const auto& t : tests) out["tests"].push_back(DbbTestJson(t, dbb::AnalyzeCircularTest(t)));
  out["pairs"] = nlohmann::json::array();
  return out;
}

nlohmann::json DbbTraceJson(const dbb::DbbTest& test, const dbb::CircularTestResult& r) {
  nlohmann::json j;
  j["test_id"] = test.test_id;
  j["direction"] = dbb::ToString(test.direction);
  j["mode"] = dbb::ToString(r.mode);
  j["radius_mm"] = test.radius_mm;
  j["angle_deg"] = r.angle_deg;
  j["radial_error_um"] = r.radial_error_um;
  return j;
}

}  // namespace km::server
