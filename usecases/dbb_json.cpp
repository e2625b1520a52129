#include "usecases/dbb_json.h"

namespace km::usecases {

using dbb::DbbPairReport;
using dbb::DbbReport;
using dbb::DbbTestReport;

namespace {

const char* Over(bool full_turn) {
  return full_turn ? "full_turn" : "partial_arc";
}

nlohmann::json Values(const std::vector<double>& v) {
  if (v.size() == 1) return v[0];
  return nlohmann::json(v);
}

}  // namespace

nlohmann::json DbbTestToJson(const DbbTestReport& t) {
  const auto& c = t.circular;
  nlohmann::json j;
  j["test_id"] = c.test_id;
  j["direction"] = ToString(c.direction);
  j["mode"] = ToString(c.mode);
  j["plane"] = ToString(t.plane);
  // Units of every deviation of this test (circular_test.h): the bar deviation × the factor.
  j["deviation_units"] = ToString(c.units);
  j["bar_to_tool_path_factor"] = c.deviation_factor;
  j["centre_offset_um"] = {c.centre_offset_um[0], c.centre_offset_um[1]};
  j["average_radial_error_um"] = c.average_radial_error_um;
  j["circularity_um"] = c.circularity_um;
  j["min_zone_circularity_um"] = t.min_zone_circularity_um;
  j["iso230_4"] = {{"circular_deviation_um", t.iso230_4.circular_deviation_um},
                   {"radial_deviation_max_um", t.iso230_4.radial_deviation_max_um},
                   {"radial_deviation_min_um", t.iso230_4.radial_deviation_min_um},
                   {"radial_reference", t.iso230_4.radial_reference},
                   {"deviation_units", ToString(t.iso230_4.units)},
                   {"evaluated_over", Over(t.iso230_4.full_turn)},
                   {"evaluated_arc_deg", t.iso230_4.evaluated_arc_deg}};
  // Every figure of this test is over the evaluated turn or partial arc (circular_test.h).
  j["evaluated_over"] = Over(c.full_turn);
  j["evaluated_arc_deg"] = c.arc_deg;
  nlohmann::json h = nlohmann::json::array();
  for (const auto& k : t.harmonics.harmonics) {
    h.push_back({{"order", k.order}, {"amplitude_um", k.amplitude_um}, {"phase_deg", k.phase_deg}});
  }
  j["harmonics"] = h;
  nlohmann::json d = nlohmann::json::array();
  for (const auto& e : t.diagnosis) {
    nlohmann::json x = {
        {"effect", e.effect},
        {"value", Values(e.value)},
        {"unit", e.unit},
        {"contribution_pct", e.contribution_pct.empty() ? 0.0 : e.contribution_pct[0]},
        {"uncertainty", Values(e.uncertainty)},
        {"significance", e.significance}};
    for (const auto& [k, v] : e.shape) x[k] = v;
    for (const auto& [k, v] : e.shape_uncertainty) x[k + "_uncertainty"] = v;
    if (!e.shape_kind.empty()) x["spike_shape"] = e.shape_kind;
    d.push_back(x);
  }
  j["diagnosis"] = d;
  j["not_identifiable"] = t.not_identifiable;
  j["sample_count"] = c.sample_count;
  j["turn_start_deg"] = c.turn_start_deg;
  j["turn_end_deg"] = c.turn_end_deg;
  j["fit_rms_um"] = c.fit_rms_um;
  j["min_zone_centre_um"] = {t.min_zone.centre.x(), t.min_zone.centre.y()};
  if (c.radial_error_range_um) j["radial_error_range_um"] = *c.radial_error_range_um;
  if (c.machine_centre_error_um) {
    j["machine_centre_error_um"] = {(*c.machine_centre_error_um)[0],
                                    (*c.machine_centre_error_um)[1]};
  }
  return j;
}

nlohmann::json DbbPairToJson(const DbbPairReport& p) {
  // H about the common least-squares centre is the ISO 230-4 figure; about each trace's own
  // centre a second one (iso230.h).
  return {{"test_id", p.test_id},
          {"deviation_units", ToString(p.iso230_4.units)},
          {"circular_hysteresis_um", p.iso230_4.circular_hysteresis_um},
          {"circular_hysteresis_centre", "common least-squares centre"},
          {"circular_hysteresis_own_centres_um", p.iso230_4.circular_hysteresis_own_centres_um},
          {"circular_hysteresis_own_centres_centre", "own least-squares centre of each trace"},
          {"bidirectional_circular_deviation_um", p.iso230_4.bidirectional_circular_deviation_um},
          {"bidirectional_centre", "common least-squares centre"},
          {"evaluated_over", Over(p.iso230_4.full_turn)},
          {"evaluated_arc_deg", p.iso230_4.evaluated_arc_deg}};
}

nlohmann::json DbbReportToJson(const DbbReport& r) {
  nlohmann::json tests = nlohmann::json::array();
  for (const auto& t : r.tests) tests.push_back(DbbTestToJson(t));
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& p : r.pairs) pairs.push_back(DbbPairToJson(p));
  return {{"tests", tests}, {"pairs", pairs}};
}

}  // namespace km::usecases
