// Accuracy-audit rules and their evaluation (server/audits/accuracy_audit.h), pure: rules validated
// with errors naming rules[i].field, metrics read from result objects as stored, and verdicts
// with exact levels, findings and evidence for absolute and trend rules.
#include "server/audits/accuracy_audit.h"

#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "server/audits/audit_verdict.h"

namespace km::server::test {
namespace {

using nlohmann::json;

std::string FieldOf(const json& rules) {
  try {
    ParseAuditRules(rules);
  } catch (const InvalidInput& e) {
    return e.field() + ": " + e.reason();
  }
  return "accepted";
}

TEST(AccuracyAuditRules, BadRulesNameTheRuleIndexAndTheField) {
  const json ok = {{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 5}, {"stop", 20}};
  EXPECT_EQ(FieldOf(json::array({ok})), "accepted");
  EXPECT_EQ(
      FieldOf(json::array({ok, {{"kind", "laser"}, {"metric", "x"}, {"warn", 1}}})).substr(0, 14),
      "rules[1].kind:");
  EXPECT_EQ(FieldOf(json::array({{{"kind", "dbb"}, {"metric", "flatness_lsq_um"}, {"warn", 1}}}))
                .substr(0, 16),
            "rules[0].metric:");
  EXPECT_EQ(FieldOf(json::array(
                {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 30}, {"stop", 20}}})),
            "rules[0].warn: must be ≤ stop");
  EXPECT_EQ(FieldOf(json::array({{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", "5"}}})),
            "rules[0].warn: must be a finite number");
  EXPECT_EQ(FieldOf(json::array({{{"kind", "dbb"}, {"metric", "circularity_um"}}})),
            "rules[0].warn: a rule needs warn, stop or both");
  EXPECT_EQ(
      FieldOf(
          json::array(
              {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 1}, {"change", "days"}}}))
          .substr(0, 14),
      "rules[0].days:");
  EXPECT_EQ(
      FieldOf(
          json::array(
              {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 1}, {"change", "weekly"}}}))
          .substr(0, 16),
      "rules[0].change:");
  EXPECT_EQ(
      FieldOf(
          json::array(
              {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 1}, {"colour", "red"}}}))
          .substr(0, 16),
      "rules[0].colour:");
  EXPECT_EQ(FieldOf(json::array({1})), "rules[0]: must be an object");
  EXPECT_EQ(FieldOf(json::object()), "rules: must be an array of rules");
  EXPECT_EQ(FieldOf(json(std::vector<json>(201, ok))).substr(0, 6), "rules:");
  EXPECT_EQ(FieldOf(json(std::vector<json>(200, ok))), "accepted");
}

TEST(AccuracyAuditRules, DiagnosisMetricsAreTheEffectNamesOfADbbDiagnosis) {
  EXPECT_TRUE(FindAuditMetric("dbb", "diagnosis.backlash_x"));
  EXPECT_TRUE(FindAuditMetric("dbb", "diagnosis.reversal_spike_z"));
  EXPECT_TRUE(FindAuditMetric("dbb", "diagnosis.squareness"));
  EXPECT_FALSE(FindAuditMetric("dbb", "diagnosis.backlash_q"));
  EXPECT_FALSE(FindAuditMetric("dbb", "diagnosis.<effect>"));
  EXPECT_FALSE(FindAuditMetric("flatness", "diagnosis.backlash_x"));
}

TEST(AccuracyAuditMetrics, ValuesAreReadFromStoredResultsAsMagnitudes) {
  const json dbb = {{"circularity_um", 7.5},
                    {"centre_offset_um", {3.0, -4.0}},
                    {"average_radial_error_um", -2.5},
                    {"iso230_4", {{"circular_deviation_um", 9.25}}},
                    {"diagnosis",
                     {{{"effect", "backlash_x"}, {"value", -1.75}, {"unit", "µm"}},
                      {{"effect", "centre_offset"}, {"value", {6, 8}}}}}};
  const auto value = [](const std::string& kind, const std::string& metric, const json& r) {
    return ExtractAuditMetric(*FindAuditMetric(kind, metric), r);
  };
  EXPECT_EQ(value("dbb", "circularity_um", dbb), 7.5);
  EXPECT_EQ(value("dbb", "centre_offset_um", dbb), 5.0);
  EXPECT_EQ(value("dbb", "average_radial_error_um", dbb), 2.5);
  EXPECT_EQ(value("dbb", "circular_deviation_um", dbb), 9.25);
  EXPECT_EQ(value("dbb", "diagnosis.backlash_x", dbb), 1.75);
  EXPECT_EQ(value("dbb", "diagnosis.centre_offset", dbb), 10.0);
  EXPECT_FALSE(value("dbb", "diagnosis.backlash_y", dbb));
  EXPECT_FALSE(value("dbb", "min_zone_circularity_um", dbb));
  EXPECT_EQ(
      value("dbb", "circular_hysteresis_um", json{{"pair", {{"circular_hysteresis_um", 3.5}}}}),
      3.5);
  EXPECT_EQ(value("tracker", "volumetric_error_max_um",
                  json{{"volumetric_error_um", {{1, 2, 2}, {0, 0, 1}, {nullptr, 0, 0}}}}),
            3.0);
  EXPECT_EQ(value("servo", "joint_resistance_max_Nm",
                  json{{"legs", {{{"resistance_Nm", 0.5}}, {{"resistance_Nm", 1.25}}}}}),
            1.25);
  EXPECT_EQ(value("straightness", "straightness_lsq_um", json{{"straightness_lsq_um", 4}}), 4.0);
  EXPECT_EQ(value("flatness", "flatness_min_zone_um", json{{"flatness_min_zone_um", 6}}), 6.0);
  EXPECT_EQ(value("parallelism", "parallelism_um", json{{"parallelism_um", 2}}), 2.0);
  const json newest = {{"parameters", {{"strut_offset_um", {2, -3, 1, 0.5, -7.5, 4}}}}};
  const json previous = {{"parameters", {{"strut_offset_um", {1, -2, 3, -4, 5, -6}}}}};
  EXPECT_EQ(value("calibration", "strut_offset_max_um", newest), 7.5);
  EXPECT_EQ(value("calibration", "strut_offset_change_max_um",
                  json{{"newest", newest}, {"previous", previous}}),
            12.5);
  // Offsets of another number of struts, or missing ones, are no change.
  EXPECT_FALSE(value(
      "calibration", "strut_offset_change_max_um",
      json{{"newest", newest}, {"previous", {{"parameters", {{"strut_offset_um", {1, 2}}}}}}}));
  EXPECT_FALSE(value("calibration", "strut_offset_change_max_um", json{{"newest", newest}}));
  EXPECT_FALSE(value("calibration", "strut_offset_max_um", json{{"parameters", json::object()}}));
  EXPECT_FALSE(FindAuditMetric("calibration", "circularity_um"));
}

AuditRule Rule(const std::string& metric, double warn, double stop) {
  return ParseAuditRules(
      json::array({{{"kind", "dbb"}, {"metric", metric}, {"warn", warn}, {"stop", stop}}}))[0];
}

AuditEvidence Newest(double v, std::int64_t id) {
  SetUpEvidence s;
  s.test_id = "xy-r150";
  s.direction = "ccw";
  s.newest = AuditValue{v, MeasurementId(id), "2026-11-20T08:00:00Z"};
  AuditEvidence e;
  e.set_ups.push_back(s);
  return e;
}

TEST(AccuracyAuditEvaluation, LevelIsTheWorstFindingWithItsEvidence) {
  const std::vector<AuditRule> rules = {
      Rule("circularity_um", 5, 20), Rule("centre_offset_um", 10, 30),
      Rule("circular_deviation_um", 1, 2), Rule("min_zone_circularity_um", 5, 20)};
  const json v = EvaluateAudit(rules, {Newest(7.5, 42), Newest(31, 43), Newest(0.5, 44), {}});
  EXPECT_EQ(v["level"], 3);
  ASSERT_EQ(v["findings"].size(), 2u);
  const json& f0 = v["findings"][0];
  EXPECT_EQ(f0["rule"], 0);
  EXPECT_EQ(f0["metric"], "circularity_um");
  EXPECT_EQ(f0["level"], 2);
  EXPECT_EQ(f0["value"], 7.5);
  EXPECT_EQ(f0["limit"], 5.0);
  EXPECT_EQ(f0["measurement_id"], 42);
  EXPECT_EQ(f0["measured_at"], "2026-11-20T08:00:00Z");
  EXPECT_EQ(f0["message"],
            "dbb circularity_um in xy-r150 CCW 7.5, above the warn limit 5 (measurement 42)");
  EXPECT_EQ(v["findings"][1]["level"], 3);
  EXPECT_EQ(v["findings"][1]["limit"], 30.0);
  ASSERT_EQ(v["checked"].size(), 4u);
  EXPECT_EQ(v["checked"][2]["status"], "ok");
  EXPECT_EQ(v["checked"][2]["value"], 0.5);
  EXPECT_EQ(v["checked"][3]["status"], "not evaluated");
  EXPECT_EQ(v["checked"][3]["reason"], "no result of this metric yet");
  EXPECT_EQ(f0["set_up"], "xy-r150 CCW");
}

TEST(AccuracyAuditEvaluation, NoFindingsIsLevelOneAndLimitsAreExclusive) {
  const json v = EvaluateAudit({Rule("circularity_um", 5, 20)}, {Newest(5.0, 1)});
  EXPECT_EQ(v["level"], 1);
  EXPECT_TRUE(v["findings"].empty());
  EXPECT_EQ(v["checked"][0]["status"], "ok");
  EXPECT_EQ(EvaluateAudit({}, {})["level"], 1);
}

TEST(AccuracyAuditEvaluation, TrendRulesCompareTheIncreaseOverTheReference) {
  auto rule = ParseAuditRules(json::array({{{"kind", "dbb"},
                                            {"metric", "circularity_um"},
                                            {"change", "days"},
                                            {"days", 30},
                                            {"warn", 5},
                                            {"stop", 8}}}))[0];
  AuditEvidence rose = Newest(10, 9);
  rose.set_ups[0].reference = AuditValue{3, MeasurementId(4), "2026-10-01T00:00:00Z"};
  const json v = EvaluateAudit({rule}, {rose});
  EXPECT_EQ(v["level"], 2);
  const json& f = v["findings"][0];
  EXPECT_EQ(f["value"], 7.0);
  EXPECT_EQ(f["limit"], 5.0);
  EXPECT_EQ(f["measurement_id"], 9);
  EXPECT_EQ(f["newest_value"], 10.0);
  EXPECT_EQ(f["reference_value"], 3.0);
  EXPECT_EQ(f["reference_measurement_id"], 4);
  EXPECT_EQ(f["message"],
            "dbb circularity_um in xy-r150 CCW rose by 7 (from 3 to 10), above the warn limit 5 "
            "(measurement 9)");

  AuditEvidence fell = Newest(3, 9);
  fell.set_ups[0].reference = AuditValue{30, MeasurementId(4), "2026-10-01T00:00:00Z"};
  EXPECT_EQ(EvaluateAudit({rule}, {fell})["level"], 1);
  EXPECT_EQ(EvaluateAudit({rule}, {fell})["checked"][0]["value"], -27.0);

  const json none = EvaluateAudit({rule}, {Newest(10, 9)});
  EXPECT_EQ(none["level"], 1);
  EXPECT_EQ(none["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(none["checked"][0]["reason"], "no reference value to compare with");
}

}  // namespace
}  // namespace km::server::test
