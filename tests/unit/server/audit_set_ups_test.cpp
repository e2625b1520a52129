// Accuracy audits judge every set-up of a machine (server/audits/audit_gather.h), over a real
// service and SQLite file. The DBB files are written here from first principles: a bar whose
// length varies as A·cos 2θ (an oval path, which no centre offset or radius change removes)
// has circularity F = 2A exactly (samples every degree hit the extremes), so each set-up's
// value is known without running the analysis under test. Checked: a session of several
// set-ups measured together (one above stop, one between warn and stop, one within), the level
// the worst of them with the right measurement named; a set-up repaired and measured again is
// judged on its new test; a stale set-up listed with its date and, when asked, a warn finding;
// scoped rules (exact test_id, a pattern, a direction) apply only where they say; trends per
// set-up; H per test_id's pair.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <sstream>
#include <string>

#include "analysis/core/errors.h"
#include "server/audits/audit_service.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server::test {
namespace {

using nlohmann::json;

constexpr const char* kSetUpMachine = "vmc-12";
constexpr std::int64_t kAuditNow = 1795749120;  // 2026-11-27T03:12:00Z

// A DBB file whose bar length varies by amplitude_um·cos 2θ: circularity F = 2·amplitude_um.
std::string OvalDbb(const std::string& test_id, const std::string& direction, double amplitude_um,
                    const std::string& timestamp) {
  std::ostringstream o;
  o << "# format: kinemetric-dbb/1\n# machine_id: " << kSetUpMachine << "\n# test_id: " << test_id
    << "\n# direction: " << direction << "\n# plane: XY\n# bar_length_mm: 100\n"
    << "# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n# timestamp: " << timestamp
    << "\nangle_deg,dr_um\n";
  for (int k = 0; k <= 360; ++k) {
    const int angle = direction == "cw" ? 360 - k : k;
    const double t = angle * M_PI / 180.0;
    o << angle << ',' << amplitude_um * std::cos(2.0 * t) << '\n';
  }
  return o.str();
}

class AuditSetUps : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("k.db")), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  MeasurementId Upload(const std::string& text, const std::string& name) {
    return svc_->measurements().Upload(text, name).id;
  }
  json Audit(const json& body, std::int64_t now = kAuditNow) {
    PutAuditConfig(*svc_, kSetUpMachine, body, now);
    return RunAccuracyAudit(*svc_, kSetUpMachine, "manual", now);
  }
  static json Circularity(double warn, double stop) {
    return {{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", warn}, {"stop", stop}};
  }
  // The checked entries of one rule, by set-up name.
  static std::map<std::string, json> Checked(const json& verdict, int rule) {
    std::map<std::string, json> out;
    for (const auto& c : verdict["checked"]) {
      if (c["rule"] == rule) out[c.value("set_up", "")] = c;
    }
    return out;
  }
  std::unique_ptr<Service> svc_;
};

TEST_F(AuditSetUps, EverySetUpOfASessionIsJudgedAndTheWorstDecides) {
  // One session: the newest test (yz) is good; the xy-r100 CW circle is above stop.
  const auto above = Upload(OvalDbb("xy-r100", "cw", 20.35, "2026-11-26T08:00:00Z"), "a.txt");
  const auto between = Upload(OvalDbb("xy-r150", "ccw", 10.0, "2026-11-26T08:10:00Z"), "b.txt");
  const auto newest = Upload(OvalDbb("yz-r150", "ccw", 3.8, "2026-11-26T08:20:00Z"), "c.txt");
  ASSERT_NEAR(svc_->measurements().Results(above)["circularity_um"].get<double>(), 40.7, 1e-6);
  const json v = Audit({{"rules", {Circularity(15, 30)}}});
  EXPECT_EQ(v["level"], 3) << v.dump(1);
  ASSERT_EQ(v["findings"].size(), 2u) << v.dump(1);
  // Findings in the order of the set-ups, newest first.
  const json& stop = v["findings"][1];
  EXPECT_EQ(stop["level"], 3);
  EXPECT_EQ(stop["measurement_id"], nlohmann::json(above));
  EXPECT_EQ(stop["set_up"], "xy-r100 CW");
  EXPECT_EQ(stop["test_id"], "xy-r100");
  EXPECT_EQ(stop["direction"], "cw");
  EXPECT_NEAR(stop["value"].get<double>(), 40.7, 1e-6);
  EXPECT_EQ(stop["message"],
            "dbb circularity_um in xy-r100 CW 40.7, above the stop limit 30 (measurement " +
                to_string(above) + ")");
  EXPECT_EQ(v["findings"][0]["level"], 2);
  EXPECT_EQ(v["findings"][0]["measurement_id"], nlohmann::json(between));
  const auto checked = Checked(v, 0);
  ASSERT_EQ(checked.size(), 3u);
  EXPECT_EQ(checked.at("yz-r150 CCW")["status"], "ok");
  EXPECT_EQ(checked.at("yz-r150 CCW")["measurement_id"], nlohmann::json(newest));
  EXPECT_NEAR(checked.at("yz-r150 CCW")["value"].get<double>(), 7.6, 1e-6);
}

TEST_F(AuditSetUps, ARepairedSetUpIsJudgedOnItsNewTestAndAStaleOneIsListed) {
  Upload(OvalDbb("xy-r150", "ccw", 20.0, "2026-11-20T08:00:00Z"), "before.txt");
  const auto repaired = Upload(OvalDbb("xy-r150", "ccw", 2.5, "2026-11-25T08:00:00Z"), "after.txt");
  const auto old = Upload(OvalDbb("zx-r150", "ccw", 25.0, "2025-06-01T08:00:00Z"), "old.txt");
  json body = {{"rules", {Circularity(15, 30)}}, {"max_age_days", 180}};
  const json quiet = Audit(body);
  EXPECT_EQ(quiet["level"], 1) << quiet.dump(1);
  const auto checked = Checked(quiet, 0);
  EXPECT_EQ(checked.at("xy-r150 CCW")["measurement_id"], nlohmann::json(repaired));
  EXPECT_EQ(checked.at("xy-r150 CCW")["status"], "ok");
  EXPECT_EQ(checked.at("zx-r150 CCW")["status"], "stale");
  EXPECT_EQ(checked.at("zx-r150 CCW")["measured_at"], "2025-06-01T08:00:00Z");
  ASSERT_EQ(quiet["stale"].size(), 1u);
  EXPECT_EQ(quiet["stale"][0]["measurement_id"], nlohmann::json(old));
  EXPECT_EQ(quiet["stale"][0]["set_up"], "zx-r150 CCW");

  body["stale"] = "warn";
  const json warned = Audit(body);
  EXPECT_EQ(warned["level"], 2);
  ASSERT_EQ(warned["findings"].size(), 1u);
  EXPECT_EQ(warned["findings"][0]["measurement_id"], nlohmann::json(old));
  EXPECT_EQ(warned["findings"][0]["level"], 2);
  EXPECT_EQ(warned["findings"][0]["stale"], true);
  EXPECT_EQ(AuditConfigJson(*svc_, kSetUpMachine)["stale"], "warn");
  EXPECT_EQ(AuditConfigJson(*svc_, kSetUpMachine)["max_age_days"], 180);

  // Within the default of 365 days the old set-up is judged (and is above warn).
  const json judged = Audit({{"rules", {Circularity(15, 60)}}}, kAuditNow - 200 * 86400);
  EXPECT_EQ(judged["level"], 2);
}

TEST_F(AuditSetUps, ScopedRulesApplyOnlyWhereTheySay) {
  const auto r100cw = Upload(OvalDbb("xy-r100", "cw", 20.0, "2026-11-26T08:00:00Z"), "a.txt");
  const auto r100ccw = Upload(OvalDbb("xy-r100", "ccw", 12.0, "2026-11-26T08:05:00Z"), "b.txt");
  const auto r150 = Upload(OvalDbb("xy-r150", "ccw", 12.0, "2026-11-26T08:10:00Z"), "c.txt");
  json only_r150 = Circularity(20, 30);
  only_r150["test_id"] = "xy-r150";
  json ccw = Circularity(20, 30);
  ccw["direction"] = "CCW";
  json pattern = Circularity(30, 38);
  pattern["test_id"] = "xy-r1*0";
  const json v = Audit({{"rules", {only_r150, ccw, pattern}}});
  EXPECT_EQ(Checked(v, 0).size(), 1u);
  EXPECT_EQ(Checked(v, 0).begin()->second["measurement_id"], nlohmann::json(r150));
  EXPECT_EQ(Checked(v, 0).begin()->second["level"], 2);
  const auto by_direction = Checked(v, 1);
  ASSERT_EQ(by_direction.size(), 2u);
  EXPECT_EQ(by_direction.count("xy-r100 CW"), 0u);
  EXPECT_EQ(by_direction.at("xy-r100 CCW")["measurement_id"], nlohmann::json(r100ccw));
  EXPECT_EQ(Checked(v, 2).size(), 3u);
  EXPECT_EQ(Checked(v, 2).at("xy-r100 CW")["measurement_id"], nlohmann::json(r100cw));
  EXPECT_EQ(Checked(v, 2).at("xy-r100 CW")["level"], 3);
  EXPECT_EQ(v["level"], 3);
  EXPECT_EQ(AuditConfigJson(*svc_, kSetUpMachine)["rules"][1]["direction"], "ccw");

  json none = Circularity(1, 2);
  none["test_id"] = "yz-*";
  const json empty = Audit({{"rules", {none}}});
  EXPECT_EQ(empty["level"], 1);
  EXPECT_EQ(empty["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(empty["checked"][0]["reason"], "no dbb result of this machine in test_id yz-* yet");

  const auto refused = [&](json rule, const std::string& field) {
    try {
      PutAuditConfig(*svc_, kSetUpMachine, {{"rules", {rule}}}, kAuditNow);
      ADD_FAILURE() << rule.dump();
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  json bad = Circularity(1, 2);
  bad["direction"] = "up";
  refused(bad, "rules[0].direction");
  bad = Circularity(1, 2);
  bad["axis"] = "X";
  refused(bad, "rules[0].axis");
  bad = Circularity(1, 2);
  bad["test_id"] = "";
  refused(bad, "rules[0].test_id");
  bad = Circularity(1, 2);
  bad["test_id"] = 7;
  refused(bad, "rules[0].test_id");
  refused(json{{"kind", "servo"}, {"metric", "joint_level"}, {"warn", 1}, {"test_id", "a"}},
          "rules[0].test_id");
  try {
    PutAuditConfig(*svc_, kSetUpMachine, {{"rules", json::array()}, {"max_age_days", 0}},
                   kAuditNow);
    ADD_FAILURE();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("max_age_days"), std::string::npos);
  }
  EXPECT_THROW(PutAuditConfig(*svc_, kSetUpMachine, {{"rules", json::array()}, {"stale", "loud"}},
                              kAuditNow),
               InvalidInput);
}

TEST_F(AuditSetUps, TrendsCompareEachSetUpWithItsOwnHistory) {
  // xy-r150 grew by 10 µm of F in two months; yz-r150 has no history at all.
  Upload(OvalDbb("xy-r150", "ccw", 5.0, "2026-09-20T08:00:00Z"), "a.txt");
  const auto grown = Upload(OvalDbb("xy-r150", "ccw", 10.0, "2026-11-26T08:00:00Z"), "b.txt");
  Upload(OvalDbb("yz-r150", "ccw", 3.0, "2026-11-26T08:30:00Z"), "c.txt");
  const json rule = {{"kind", "dbb"},    {"metric", "circularity_um"},
                     {"change", "days"}, {"days", 60},
                     {"warn", 5},        {"stop", 20}};
  const json v = Audit({{"rules", {rule}}});
  EXPECT_EQ(v["level"], 2) << v.dump(1);
  const auto checked = Checked(v, 0);
  EXPECT_EQ(checked.at("xy-r150 CCW")["measurement_id"], nlohmann::json(grown));
  EXPECT_NEAR(checked.at("xy-r150 CCW")["value"].get<double>(), 10.0, 1e-6);
  EXPECT_EQ(checked.at("yz-r150 CCW")["status"], "not evaluated");

  // Against the previous audit: each set-up with the value that audit saw of it.
  json previous = rule;
  previous["change"] = "previous_audit";
  previous.erase("days");
  const json first = Audit({{"rules", {previous}}});
  EXPECT_EQ(first["level"], 1);
  Upload(OvalDbb("yz-r150", "ccw", 9.0, "2026-11-26T09:00:00Z"), "d.txt");
  const json second = Audit({{"rules", {previous}}});
  EXPECT_EQ(second["level"], 2) << second.dump(1);
  EXPECT_NEAR(Checked(second, 0).at("yz-r150 CCW")["value"].get<double>(), 12.0, 1e-6);
  EXPECT_NEAR(Checked(second, 0).at("xy-r150 CCW")["value"].get<double>(), 0.0, 1e-9);
}

TEST_F(AuditSetUps, HysteresisIsJudgedForEachTestIdsPair) {
  // xy-r150: the CW path is 5 µm more oval than the CCW one (the paths differ by 5·cos 2θ, so
  // H ≥ 5 µm); the newest set-up, yz-r150, runs the same path both ways (H ≈ 0).
  Upload(OvalDbb("xy-r150", "ccw", 3.0, "2026-11-26T08:00:00Z"), "a.txt");
  Upload(OvalDbb("xy-r150", "cw", 8.0, "2026-11-26T08:05:00Z"), "b.txt");
  Upload(OvalDbb("yz-r150", "ccw", 3.0, "2026-11-26T08:30:00Z"), "c.txt");
  Upload(OvalDbb("yz-r150", "cw", 3.0, "2026-11-26T08:35:00Z"), "d.txt");
  const json v =
      Audit({{"rules", {{{"kind", "dbb"}, {"metric", "circular_hysteresis_um"}, {"warn", 4}}}}});
  const auto checked = Checked(v, 0);
  ASSERT_EQ(checked.size(), 2u) << v.dump(1);
  EXPECT_LT(checked.at("yz-r150")["value"].get<double>(), 0.5);
  EXPECT_EQ(v["level"], 2) << v.dump(1);
  EXPECT_EQ(v["findings"][0]["set_up"], "xy-r150");
  EXPECT_GE(v["findings"][0]["value"].get<double>(), 5.0 - 1e-6);
}

// Conformance as a rule: a set-up whose newest test fails the machine's tolerances is a finding
// of the rule's level; a set-up no tolerance applies to is not evaluated; a new table judges the
// same tests again.
TEST_F(AuditSetUps, ASetUpFailingItsTolerancesIsAFindingOfTheRulesLevel) {
  const auto r100 = Upload(OvalDbb("xy-r100", "cw", 8.0, "2026-11-26T08:00:00Z"), "a.txt");
  Upload(OvalDbb("xy-r150", "ccw", 5.0, "2026-11-26T08:10:00Z"), "b.txt");
  Upload(OvalDbb("yz-r150", "ccw", 5.0, "2026-11-26T08:20:00Z"), "c.txt");
  // ISO 230-4 G of an oval A·cos 2θ is 2A: 16 µm, 10 µm and 10 µm.
  svc_->tolerances().Put(kSetUpMachine, {{"tolerances",
                                          {{{"kind", "dbb"},
                                            {"metric", "circular_deviation_um"},
                                            {"test_id", "xy-*"},
                                            {"tolerance", 15}}}}});
  const json rule = {{"kind", "dbb"}, {"metric", "conformance"}, {"level", 2}};
  const json v = Audit({{"rules", {rule}}});
  EXPECT_EQ(v["level"], 2) << v.dump(1);
  ASSERT_EQ(v["findings"].size(), 1u) << v.dump(1);
  EXPECT_EQ(v["findings"][0]["measurement_id"], nlohmann::json(r100));
  EXPECT_EQ(v["findings"][0]["conformance"], "fail");
  EXPECT_EQ(v["findings"][0]["tolerance_version"], 1);
  const auto checked = Checked(v, 0);
  EXPECT_EQ(checked.at("xy-r150 CCW")["status"], "ok");
  EXPECT_EQ(checked.at("xy-r150 CCW")["conformance"], "pass");
  EXPECT_EQ(checked.at("yz-r150 CCW")["status"], "not evaluated");

  // A tighter table: every set-up fails; without a level the rule stops the machine.
  svc_->tolerances().Put(
      kSetUpMachine,
      {{"tolerances",
        {{{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", 9.5}}}}});
  const json again = Audit({{"rules", {{{"kind", "dbb"}, {"metric", "conformance"}}}}});
  EXPECT_EQ(again["level"], 3);
  EXPECT_EQ(again["findings"].size(), 3u);
  EXPECT_EQ(again["findings"][0]["tolerance_version"], 2);
  EXPECT_EQ(AuditConfigJson(*svc_, kSetUpMachine)["rules"][0]["stop"], 0.0);

  json bad = rule;
  bad["level"] = 1;
  EXPECT_THROW(PutAuditConfig(*svc_, kSetUpMachine, {{"rules", {bad}}}, kAuditNow), InvalidInput);
  bad = rule;
  bad["change"] = "previous_audit";
  EXPECT_THROW(PutAuditConfig(*svc_, kSetUpMachine, {{"rules", {bad}}}, kAuditNow), InvalidInput);
  bad = Circularity(1, 2);
  bad["level"] = 3;
  EXPECT_THROW(PutAuditConfig(*svc_, kSetUpMachine, {{"rules", {bad}}}, kAuditNow), InvalidInput);
  EXPECT_THROW(
      PutAuditConfig(*svc_, kSetUpMachine,
                     {{"rules", {{{"kind", "servo"}, {"metric", "conformance"}}}}}, kAuditNow),
      InvalidInput);
}

// The demo machine as a plant measures it: several circles in one session. The newest test is
// within the limits; the audit must still find the circle above stop, naming it.
TEST_F(AuditSetUps, TheDemoMachinesCircleAboveStopIsFoundThoughANewerTestIsGood) {
  for (const auto& f : DemoDbbFiles()) svc_->measurements().Upload(f.bytes, f.name);
  MeasurementFilter all;
  all.machine_id = "demo-vmc";
  all.kind = "dbb";
  all.limit = 1000;
  double worst = 0.0;
  MeasurementId worst_id;
  for (const auto& r : svc_->storage().ListMeasurements(all).items) {
    // Only each set-up's newest test counts; the demo holds older tests of xy-r150 too.
    MeasurementFilter same = all;
    same.test_id = r.test_id;
    same.direction = r.direction;
    same.order = MeasurementFilter::Order::kNewest;
    same.limit = 1;
    if (svc_->storage().ListMeasurements(same).items.front().id != r.id) continue;
    const double f = svc_->measurements().Results(r.id)["circularity_um"].get<double>();
    if (f > worst) {
      worst = f;
      worst_id = r.id;
    }
  }
  ASSERT_GT(worst, 0.0);
  PutAuditConfig(*svc_, "demo-vmc",
                 {{"rules",
                   {{{"kind", "dbb"},
                     {"metric", "circularity_um"},
                     {"warn", worst / 3},
                     {"stop", worst - 0.01}}}}},
                 kAuditNow);
  const json v = RunAccuracyAudit(*svc_, "demo-vmc", "manual", kAuditNow);
  EXPECT_EQ(v["level"], 3) << v.dump(1);
  bool named = false;
  for (const auto& f : v["findings"]) {
    if (f["level"] == 3) {
      EXPECT_EQ(f["measurement_id"], nlohmann::json(worst_id));
      named = true;
    }
  }
  EXPECT_TRUE(named) << v.dump(1);
}

// Laser positioning: one set-up per axis; "axis" scopes a rule to one of them.
TEST_F(AuditSetUps, PositioningIsJudgedPerAxis) {
  const auto x = DemoPositioningFile();
  const auto x_id = svc_->measurements().Upload(x.bytes, x.name).id;
  std::string z = x.bytes;
  z.replace(z.find("# axis: X"), 9, "# axis: Z");
  const auto when = z.find("# timestamp: ") + 13;
  z.replace(when, z.find('\n', when) - when, "2026-11-26T09:00:00Z");
  const auto z_id = svc_->measurements().Upload(z, "z.txt").id;
  const double a_x = svc_->measurements().Results(x_id)["accuracy_um"].get<double>();
  json every = {{"kind", "positioning"}, {"metric", "accuracy_um"}, {"warn", a_x / 2}};
  json only_z = every;
  only_z["axis"] = "z";
  PutAuditConfig(*svc_, "demo-vmc", {{"rules", {every, only_z}}}, kAuditNow);
  const json v = RunAccuracyAudit(*svc_, "demo-vmc", "manual", kAuditNow);
  const auto each = Checked(v, 0);
  ASSERT_EQ(each.size(), 2u) << v.dump(1);
  EXPECT_EQ(each.at("axis X")["measurement_id"], nlohmann::json(x_id));
  EXPECT_EQ(each.at("axis Z")["measurement_id"], nlohmann::json(z_id));
  const auto one = Checked(v, 1);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one.begin()->first, "axis Z");
  EXPECT_EQ(AuditConfigJson(*svc_, "demo-vmc")["rules"][1]["axis"], "Z");
}

}  // namespace
}  // namespace km::server::test
