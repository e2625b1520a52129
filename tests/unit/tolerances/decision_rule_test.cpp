// Decision rules (server/audits/decision_rule.h, ISO 14253-1, ILAC-G8) with truths worked by
// hand: values inside, outside and within U (or the guard band) of a limit under each rule; the
// tolerance judge and the audit levels under them; every refusal naming its field.
#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "server/audits/audit_verdict.h"
#include "server/audits/decision_rule.h"
#include "server/tolerances/tolerances.h"
#include "tests/unit/expect_error.h"

namespace km::server {
namespace {

using nlohmann::json;

DecisionRule ParsedRule(const json& v) {
  return ParseDecisionRule(v, "decision_rule");
}

TEST(DecisionRules, SimpleJudgesTheValueAloneWhateverItsUncertainty) {
  const DecisionRule simple = ParsedRule("simple");
  EXPECT_EQ(Decide(14.8, 2.0, 15.0, simple).decision, Decision::kWithin);
  EXPECT_EQ(Decide(15.0, 2.0, 15.0, simple).decision, Decision::kWithin);  // equal: within
  EXPECT_EQ(Decide(15.2, 2.0, 15.0, simple).decision, Decision::kBeyond);
  EXPECT_EQ(Decide(15.2, 2.0, 15.0, simple).guard_band, 0.0);
  EXPECT_EQ(ParsedRule(nullptr).kind, DecisionRule::Kind::kSimple);  // absent: simple
}

TEST(DecisionRules, GuardedDecidesOnlyOutsideTheUncertaintyOfTheLimit) {
  // The two machines: 0.2 µm over and 0.2 µm under a 15 µm limit, U = 2 µm.
  const DecisionRule guarded = ParsedRule("guarded");
  EXPECT_EQ(Decide(15.2, 2.0, 15.0, guarded).decision, Decision::kUndecided);
  EXPECT_EQ(Decide(14.8, 2.0, 15.0, guarded).decision, Decision::kUndecided);
  EXPECT_EQ(Decide(13.0, 2.0, 15.0, guarded).decision, Decision::kWithin);  // 13 + 2 ≤ 15
  EXPECT_EQ(Decide(13.01, 2.0, 15.0, guarded).decision, Decision::kUndecided);
  EXPECT_EQ(Decide(17.0, 2.0, 15.0, guarded).decision, Decision::kUndecided);  // 17 − 2 = 15
  EXPECT_EQ(Decide(17.01, 2.0, 15.0, guarded).decision, Decision::kBeyond);
  const Judgement j = Decide(16.0, 2.0, 15.0, guarded);
  EXPECT_TRUE(j.u_known);
  EXPECT_DOUBLE_EQ(j.guard_band, 2.0);
  // U unknown: the value alone, said so.
  const Judgement unknown = Decide(15.2, std::nullopt, 15.0, guarded);
  EXPECT_EQ(unknown.decision, Decision::kBeyond);
  EXPECT_FALSE(unknown.u_known);
}

TEST(DecisionRules, AGuardBandIsAShareOfTheLimit) {
  const DecisionRule band = ParsedRule({{"rule", "guard_band"}, {"guard_band_pct", 10}});
  EXPECT_DOUBLE_EQ(band.guard_band_pct, 10.0);
  // w = 1.5 µm of a 15 µm limit, whatever U is.
  EXPECT_EQ(Decide(13.5, 0.1, 15.0, band).decision, Decision::kWithin);
  EXPECT_EQ(Decide(13.6, 0.1, 15.0, band).decision, Decision::kUndecided);
  EXPECT_EQ(Decide(16.5, 0.1, 15.0, band).decision, Decision::kUndecided);
  EXPECT_EQ(Decide(16.6, 0.1, 15.0, band).decision, Decision::kBeyond);
  EXPECT_DOUBLE_EQ(Decide(16.6, 0.1, 15.0, band).guard_band, 1.5);
  EXPECT_EQ(DecisionRuleJson(band)["guard_band_pct"], 10.0);
  EXPECT_EQ(ParsedRule(DecisionRuleJson(band)).guard_band_pct, 10.0);  // the stored form reads back
}

TEST(DecisionRules, BadRulesAreRefusedNamingTheField) {
  const auto field = [](const json& v) {
    return test::Expect<InvalidInput>([&] { ParsedRule(v); }).field();
  };
  EXPECT_EQ(field("lenient"), "decision_rule");
  EXPECT_EQ(field("guard_band"), "decision_rule");  // needs its width
  EXPECT_EQ(field(42), "decision_rule");
  EXPECT_EQ(field({{"rule", "guard_band"}}), "decision_rule.guard_band_pct");
  EXPECT_EQ(field({{"rule", "guard_band"}, {"guard_band_pct", 0}}), "decision_rule.guard_band_pct");
  EXPECT_EQ(field({{"rule", "guard_band"}, {"guard_band_pct", 101}}),
            "decision_rule.guard_band_pct");
  EXPECT_EQ(field({{"rule", "guarded"}, {"guard_band_pct", 5}}), "decision_rule.guard_band_pct");
  EXPECT_EQ(field({{"rule", "guarded"}, {"colour", 5}}), "decision_rule.colour");
  EXPECT_EQ(field({{"rule", 3}}), "decision_rule.rule");
}

json GWithU(double g, double U) {
  return {{"iso230_4", {{"circular_deviation_um", g}}},
          {"uncertainty", {{"figures", {{"circular_deviation_um", {{"U_um", U}}}}}}}};
}

ToleranceTable RuledTable(const json& rule) {
  const json body = {
      {"tolerances", {{{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", 15}}}},
      {"decision_rule", rule}};
  ToleranceTable t;
  t.machine_id = "vmc";
  t.version = 2;
  t.entries = ParseToleranceBody(body);
  t.decision_rule = ParseToleranceDecisionRule(body);
  return t;
}

TEST(DecisionRules, ConformanceNamesTheRuleAndTheUncertaintyOfEachFigure) {
  const auto simple = Conformance(RuledTable("simple"), "dbb", "xy-r150", "cw", GWithU(15.2, 2.0));
  EXPECT_EQ(simple["verdict"], "fail");
  EXPECT_EQ(simple["decision_rule"]["rule"], "simple");
  EXPECT_EQ(simple["figures"][0]["U"], 2.0);
  const auto guarded = RuledTable("guarded");
  const auto over = Conformance(guarded, "dbb", "xy-r150", "cw", GWithU(15.2, 2.0));
  EXPECT_EQ(over["verdict"], "undecided");
  EXPECT_EQ(over["figures"][0]["verdict"], "undecided");
  EXPECT_EQ(over["figures"][0]["guard_band"], 2.0);
  EXPECT_EQ(over["decision_rule"]["rule"], "guarded");
  EXPECT_EQ(Conformance(guarded, "dbb", "xy-r150", "cw", GWithU(12.9, 2.0))["verdict"], "pass");
  EXPECT_EQ(Conformance(guarded, "dbb", "xy-r150", "cw", GWithU(17.1, 2.0))["verdict"], "fail");
  // A result without an uncertainty: the value alone, with a note.
  const json bare = {{"iso230_4", {{"circular_deviation_um", 15.2}}}};
  const auto alone = Conformance(guarded, "dbb", "xy-r150", "cw", bare);
  EXPECT_EQ(alone["verdict"], "fail");
  EXPECT_TRUE(alone["figures"][0]["U"].is_null());
  EXPECT_TRUE(alone["figures"][0].contains("note"));
  // The rule is part of what makes a table the same again.
  EXPECT_NE(CanonicalToleranceText(guarded.entries, guarded.decision_rule),
            CanonicalToleranceText(guarded.entries, DecisionRule{}));
  EXPECT_EQ(CanonicalToleranceText(guarded.entries), CanonicalToleranceText(guarded.entries, {}));
}

AuditEvidence NewestWithU(double v, std::optional<double> U) {
  SetUpEvidence s;
  s.test_id = "xy-r150";
  s.direction = "ccw";
  s.newest = AuditValue{v, MeasurementId(7), "2026-11-20T08:00:00Z", std::nullopt, U};
  AuditEvidence e;
  e.set_ups.push_back(s);
  return e;
}

int AuditLevel(double v, std::optional<double> U, const json& rule) {
  const auto rules = ParseAuditRules(json::array(
      {{{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"warn", 10}, {"stop", 15}}}));
  AuditPolicy policy;
  policy.decision_rule = ParsedRule(rule);
  const json verdict = EvaluateAudit(rules, {NewestWithU(v, U)}, policy);
  EXPECT_EQ(verdict["decision_rule"]["rule"],
            policy.decision_rule.kind == DecisionRule::Kind::kSimple ? "simple" : "guarded");
  return verdict["level"].get<int>();
}

TEST(DecisionRules, AnAuditStopsOnlyAMachineProvenBeyondStop) {
  EXPECT_EQ(AuditLevel(15.2, 2.0, "simple"), 3);
  EXPECT_EQ(AuditLevel(14.8, 2.0, "simple"), 2);
  EXPECT_EQ(AuditLevel(15.2, 2.0, "guarded"), 2);           // within U of stop: undecided, warn
  EXPECT_EQ(AuditLevel(17.5, 2.0, "guarded"), 3);           // proven beyond stop
  EXPECT_EQ(AuditLevel(9.0, 2.0, "guarded"), 2);            // within U of warn
  EXPECT_EQ(AuditLevel(7.9, 2.0, "guarded"), 1);            // 7.9 + 2 ≤ 10
  EXPECT_EQ(AuditLevel(15.2, std::nullopt, "guarded"), 3);  // no U: the value alone

  const auto rules = ParseAuditRules(json::array(
      {{{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"warn", 10}, {"stop", 15}}}));
  AuditPolicy policy;
  policy.decision_rule = ParsedRule("guarded");
  const json v = EvaluateAudit(rules, {NewestWithU(15.2, 2.0)}, policy);
  ASSERT_EQ(v["findings"].size(), 1u);
  EXPECT_EQ(v["findings"][0]["decision"], "undecided");
  EXPECT_EQ(v["findings"][0]["U"], 2.0);
  EXPECT_EQ(v["findings"][0]["limit"], 15.0);
  EXPECT_NE(v["findings"][0]["message"].get<std::string>().find("undecided"), std::string::npos);
}

}  // namespace
}  // namespace km::server

namespace km::server {
namespace {

TEST(AuditInstruments, ASetUpMeasuredWithAnOverdueInstrumentIsListedAndAFindingWhenAsked) {
  const auto rules = ParseAuditRules(
      json::array({{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 10}, {"stop", 15}},
                   {{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"stop", 20}}}));
  AuditEvidence e = NewestWithU(4.0, std::nullopt);
  e.set_ups[0].overdue_instrument = {
      {"serial", "QC20-0042"}, {"instrument", "ball bar"}, {"calibration_due", "2026-06-01"}};
  AuditPolicy listed;
  const json quiet = EvaluateAudit(rules, {e, e}, listed);
  EXPECT_EQ(quiet["level"], 1);
  ASSERT_EQ(quiet["instrument_overdue"].size(), 1u);  // once, however many rules cover it
  EXPECT_EQ(quiet["instrument_overdue"][0]["serial"], "QC20-0042");
  EXPECT_EQ(quiet["instrument_overdue"][0]["measurement_id"], 7);
  EXPECT_EQ(quiet["instrument_policy"], "ignore");
  AuditPolicy warn;
  warn.instrument_overdue_warn = true;
  const json loud = EvaluateAudit(rules, {e, e}, warn);
  EXPECT_EQ(loud["level"], 2);
  ASSERT_EQ(loud["findings"].size(), 1u);
  EXPECT_EQ(loud["findings"][0]["metric"], "instrument_overdue");
  EXPECT_NE(loud["findings"][0]["message"].get<std::string>().find("2026-06-01"),
            std::string::npos);
  // A calibrated instrument: nothing listed.
  const json fine = EvaluateAudit(rules, {NewestWithU(4.0, std::nullopt)}, warn);
  EXPECT_EQ(fine["level"], 1);
  EXPECT_TRUE(fine["instrument_overdue"].empty());
}

}  // namespace
}  // namespace km::server
