// The pure judge of tolerances (server/tolerances/tolerances.h), with truths worked by hand: a
// figure equal to its tolerance is within it, the most specific entry of a metric judges, a
// pattern scope, a figure the result does not hold, and every refusal naming its field.
#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"
#include "server/tolerances/tolerances.h"
#include "tests/unit/expect_error.h"

namespace km::server {
namespace {

using nlohmann::json;

ToleranceTable Table(const json& tolerances, std::int64_t version = 3) {
  ToleranceTable t;
  t.machine_id = "vmc";
  t.version = version;
  t.entries = ParseToleranceBody({{"tolerances", tolerances}});
  return t;
}

json DbbResult(double g) {
  return {{"circularity_um", 7.5}, {"iso230_4", {{"circular_deviation_um", g}}}};
}

json G(double tolerance) {
  return {{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", tolerance}};
}

std::string FieldOf(const json& tolerances) {
  return test::Expect<InvalidInput>([&] { Table(tolerances); }).field();
}

TEST(Tolerances, AFigureEqualToItsToleranceIsWithinIt) {
  const auto t = Table(json::array({G(15)}));
  const auto pass = Conformance(t, "dbb", "xy-r150", "cw", DbbResult(14.9));
  EXPECT_EQ(pass["verdict"], "pass");
  EXPECT_EQ(pass["tolerance_version"], 3);
  ASSERT_EQ(pass["figures"].size(), 1u);
  EXPECT_EQ(pass["figures"][0]["metric"], "circular_deviation_um");
  EXPECT_EQ(pass["figures"][0]["value"], 14.9);
  EXPECT_EQ(pass["figures"][0]["tolerance"], 15.0);
  EXPECT_EQ(pass["figures"][0]["unit"], "µm");
  EXPECT_EQ(pass["figures"][0]["verdict"], "pass");
  EXPECT_EQ(Conformance(t, "dbb", "xy-r150", "cw", DbbResult(15.0))["verdict"], "pass");
  const auto fail = Conformance(t, "dbb", "xy-r150", "cw", DbbResult(15.1));
  EXPECT_EQ(fail["verdict"], "fail");
  EXPECT_EQ(fail["figures"][0]["verdict"], "fail");
  // A signed figure is judged by its magnitude.
  EXPECT_EQ(Conformance(t, "dbb", "xy-r150", "cw", DbbResult(-15.1))["verdict"], "fail");
}

TEST(Tolerances, TheMostSpecificEntryOfAMetricJudges) {
  json g20 = G(20), g15 = G(15), g10 = G(10), g8 = G(8);
  g15["test_id"] = "xy-*";
  g10["test_id"] = "xy-r150";
  g8["test_id"] = "xy-r150";
  g8["direction"] = "CW";  // read as cw
  const auto t = Table(json::array({g20, g15, g10, g8}));
  const auto tol = [&](const std::string& test_id, const std::string& dir) {
    const auto c = Conformance(t, "dbb", test_id, dir, DbbResult(1));
    EXPECT_EQ(c["figures"].size(), 1u) << c.dump();
    return c["figures"][0]["tolerance"].get<double>();
  };
  EXPECT_EQ(tol("xy-r150", "cw"), 8);    // exact test_id and direction
  EXPECT_EQ(tol("xy-r150", "ccw"), 10);  // exact test_id
  EXPECT_EQ(tol("xy-r100", "cw"), 15);   // the pattern
  EXPECT_EQ(tol("yz-r150", "cw"), 20);   // every set-up
  // The figure names the scope of the entry that judged it.
  const auto c = Conformance(t, "dbb", "xy-r150", "cw", DbbResult(9));
  EXPECT_EQ(c["figures"][0]["test_id"], "xy-r150");
  EXPECT_EQ(c["figures"][0]["direction"], "cw");
  EXPECT_EQ(c["verdict"], "fail");  // 9 > 8, although within the 10 of either direction
}

TEST(Tolerances, EquallySpecificEntriesGiveTheSmallerTolerance) {
  json a = G(15), b = G(12);
  a["test_id"] = "xy-*";
  b["test_id"] = "*-r150";
  const auto t = Table(json::array({a, b}));
  EXPECT_EQ(Conformance(t, "dbb", "xy-r150", "ccw", DbbResult(13))["figures"][0]["tolerance"],
            12.0);
  EXPECT_EQ(Conformance(t, "dbb", "xy-r100", "ccw", DbbResult(13))["verdict"], "pass");
  // A pattern matches only what it says.
  EXPECT_EQ(Conformance(t, "dbb", "yz-r100", "ccw", DbbResult(13))["verdict"], "no tolerance");
}

TEST(Tolerances, AFigureTheResultDoesNotHoldIsNoValueAndNotAPass) {
  const auto t = Table(json::array(
      {G(15), {{"kind", "dbb"}, {"metric", "diagnosis.backlash_x"}, {"tolerance", 2}}}));
  const auto c = Conformance(t, "dbb", "xy-r150", "cw", DbbResult(3));
  EXPECT_EQ(c["verdict"], "fail");
  ASSERT_EQ(c["figures"].size(), 2u);
  EXPECT_EQ(c["figures"][0]["verdict"], "pass");
  EXPECT_EQ(c["figures"][1]["verdict"], "no value");
  EXPECT_TRUE(c["figures"][1]["value"].is_null());
  // The diagnosed value is read with its unit when the result holds it.
  json r = DbbResult(3);
  r["diagnosis"] = json::array({{{"effect", "backlash_x"}, {"value", -1.5}, {"unit", "µm"}}});
  const auto d = Conformance(t, "dbb", "xy-r150", "cw", r);
  EXPECT_EQ(d["verdict"], "pass");
  EXPECT_EQ(d["figures"][1]["value"], 1.5);
  EXPECT_EQ(d["figures"][1]["unit"], "µm");
  // No result at all: every figure has no value.
  EXPECT_EQ(Conformance(t, "dbb", "xy-r150", "cw", nullptr)["verdict"], "fail");
}

TEST(Tolerances, NoEntryOfTheKindOrNoTableIsNoTolerance) {
  const auto t = Table(json::array({G(15)}));
  const auto c = Conformance(t, "flatness", "table", "", {{"flatness_min_zone_um", 3}});
  EXPECT_EQ(c["verdict"], "no tolerance");
  EXPECT_EQ(c["tolerance_version"], 3);
  EXPECT_TRUE(c["figures"].empty());
  const auto none = Conformance(ToleranceTable{}, "dbb", "xy", "cw", DbbResult(1));
  EXPECT_EQ(none["verdict"], "no tolerance");
  EXPECT_TRUE(none["tolerance_version"].is_null());
  EXPECT_EQ(Conformance(Table(json::array(), 2), "dbb", "xy", "cw", DbbResult(1))["verdict"],
            "no tolerance");
}

TEST(Tolerances, PositioningAxesAndFlatness) {
  const auto t = Table(json::array(
      {{{"kind", "positioning"}, {"metric", "accuracy_um.X"}, {"tolerance", 12}},
       {{"kind", "positioning"}, {"metric", "accuracy_um"}, {"axis", "z"}, {"tolerance", 20}},
       {{"kind", "flatness"}, {"metric", "flatness_min_zone_um"}, {"tolerance", 8}}}));
  // "accuracy_um.X" is the metric accuracy_um for axis X.
  EXPECT_EQ(t.entries[0].metric, "accuracy_um");
  EXPECT_EQ(t.entries[0].scope.axis, std::optional<std::string>("X"));
  EXPECT_EQ(t.entries[1].scope.axis, std::optional<std::string>("Z"));
  EXPECT_EQ(Conformance(t, "positioning", "X", "", {{"accuracy_um", 11.9}})["verdict"], "pass");
  EXPECT_EQ(Conformance(t, "positioning", "X", "", {{"accuracy_um", 12.1}})["verdict"], "fail");
  EXPECT_EQ(Conformance(t, "positioning", "Z", "", {{"accuracy_um", 12.1}})["verdict"], "pass");
  EXPECT_EQ(Conformance(t, "positioning", "Y", "", {{"accuracy_um", 99}})["verdict"],
            "no tolerance");
  EXPECT_EQ(Conformance(t, "flatness", "", "", {{"flatness_min_zone_um", 8.5}})["verdict"], "fail");
}

TEST(Tolerances, RefusalsNameTheField) {
  json bad_metric = G(1);
  bad_metric["metric"] = "roundness_um";
  EXPECT_EQ(FieldOf(json::array({G(1), G(2), bad_metric})), "tolerances[1]");  // G twice
  EXPECT_EQ(FieldOf(json::array({G(1), bad_metric})), "tolerances[1].metric");
  // H is read from the pair analysis, not the measurement's own result.
  json h = G(1);
  h["metric"] = "circular_hysteresis_um";
  EXPECT_EQ(FieldOf(json::array({h})), "tolerances[0].metric");
  EXPECT_EQ(
      FieldOf(json::array({{{"kind", "servo"}, {"metric", "joint_level"}, {"tolerance", 1}}})),
      "tolerances[0].kind");
  for (const json& v : {json(-0.1), json("5,5"), json(nullptr), json(true)}) {
    json e = G(1);
    e["tolerance"] = v;
    EXPECT_EQ(FieldOf(json::array({e})), "tolerances[0].tolerance") << v.dump();
  }
  json no_tol = G(1);
  no_tol.erase("tolerance");
  EXPECT_EQ(FieldOf(json::array({no_tol})), "tolerances[0].tolerance");
  json colour = G(1);
  colour["colour"] = "red";
  EXPECT_EQ(FieldOf(json::array({G(1), colour})), "tolerances[1].colour");
  json dir = {{"kind", "flatness"}, {"metric", "flatness_min_zone_um"}, {"tolerance", 1}};
  dir["direction"] = "cw";
  EXPECT_EQ(FieldOf(json::array({dir})), "tolerances[0].direction");
  json axis = {
      {"kind", "positioning"}, {"metric", "accuracy_um.X"}, {"tolerance", 1}, {"axis", "Y"}};
  EXPECT_EQ(FieldOf(json::array({axis})), "tolerances[0].axis");
  EXPECT_EQ(FieldOf(json::array({"G 15"})), "tolerances[0]");
  EXPECT_EQ(FieldOf(json::object()), "tolerances");
  json many = json::array();
  for (int i = 0; i <= 200; ++i) many.push_back(G(i));
  EXPECT_EQ(FieldOf(many), "tolerances");
  EXPECT_EQ(test::Expect<InvalidInput>([] { ParseToleranceBody(json::array()); }).field(), "body");
  EXPECT_EQ(test::Expect<InvalidInput>([] {
              ParseToleranceBody({{"tolerances", {}}, {"x", 1}});
            }).field(),
            "x");
  EXPECT_TRUE(Table(json::array()).entries.empty());  // an empty table is allowed
}

TEST(Tolerances, TheSameEntriesInAnyOrderAreTheSameTable) {
  json a = G(15), b = G(10);
  b["test_id"] = "xy-r150";
  EXPECT_EQ(CanonicalToleranceText(Table(json::array({a, b})).entries),
            CanonicalToleranceText(Table(json::array({b, a})).entries));
  const std::string before = CanonicalToleranceText(Table(json::array({a, b})).entries);
  b["tolerance"] = 11;
  EXPECT_NE(CanonicalToleranceText(Table(json::array({a, b})).entries), before);
  EXPECT_EQ(ScopeSpecificity({}), 0);
  EXPECT_EQ(ScopeSpecificity({std::string("xy-*"), std::nullopt, std::nullopt}), 2);
  EXPECT_EQ(ScopeSpecificity({std::string("xy-*"), std::string("cw"), std::nullopt}), 3);
  EXPECT_EQ(ScopeSpecificity({std::nullopt, std::nullopt, std::string("X")}), 4);
  EXPECT_EQ(ScopeSpecificity({std::string("xy-r150"), std::string("cw"), std::nullopt}), 5);
}

}  // namespace
}  // namespace km::server
