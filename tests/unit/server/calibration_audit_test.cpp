// Accuracy audits over a machine's hexapod calibrations (kind "calibration"), real service and
// SQLite file: calibration jobs stored with known strut offsets, the exact level, value, limit and
// job of each finding; another machine's calibration, failed jobs, jobs not done and a study the
// job verdict rejects are no evidence; the change since the calibration before; trend rules; the
// trend of a calibration metric with its jobs.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "server/audits/audit_schedule.h"
#include "server/audits/audit_service.h"
#include "server/audits/fleet_service.h"
#include "server/demo/demo_data.h"
#include "server/jobs/jobs.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server::test {
namespace {

using nlohmann::json;

constexpr const char* kMachine = "hexa-7";

class CalibrationAudits : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("k.db")), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  // A hexapod calibration job of the machine, stored with that status and strut offsets (µm);
  // `extra` is merged into the result. Its id.
  JobId Calibration(const std::string& machine, JobStatus status, const json& offsets,
                    const json& extra = json::object(),
                    const std::string& kind = "hexapod_calibration") {
    const json request = {{"machine_id", machine}, {"measurement_ids", {1, 2, 3}}};
    JobRecord job;
    job.id = svc_->storage().CreateJob(kind, request.dump());
    job.status = status;
    job.progress = status == JobStatus::kDone ? 1.0 : 0.0;
    json result = {{"method", "absolute"},
                   {"converged", true},
                   {"condition_number", 120.0},
                   {"parameters", {{"strut_offset_um", offsets}}}};
    result.update(extra);
    if (status == JobStatus::kDone) job.result_json = result.dump();
    if (status == JobStatus::kFailed) job.error = "the solver failed";
    svc_->storage().UpdateJob(job);
    return job.id;
  }
  json Audit(const std::string& machine, const json& rules, std::int64_t now = 1795749120) {
    PutAuditConfig(*svc_, machine, {{"rules", rules}}, now);
    return RunAccuracyAudit(*svc_, machine, "manual", now);
  }
  static json Rule(const std::string& metric, double warn, double stop) {
    return {{"kind", "calibration"}, {"metric", metric}, {"warn", warn}, {"stop", stop}};
  }
  std::string FinishedAt(JobId id) { return svc_->storage().GetJob(id)->updated_at; }

  std::unique_ptr<Service> svc_;
};

TEST_F(CalibrationAudits, TheNewestCalibrationOfTheMachineGivesLevelValueLimitAndJob) {
  const auto older = Calibration(kMachine, JobStatus::kDone, {1, -2, 3, -4, 5, -6});
  const auto newest = Calibration(kMachine, JobStatus::kDone, {2, -3, 1, 0.5, -7.5, 4});
  // None of these is evidence: another machine's, failed, still running, a study the job
  // verdict rejects (condition number not finite), another kind of job.
  Calibration("hexa-8", JobStatus::kDone, {100, 0, 0, 0, 0, 0});
  Calibration(kMachine, JobStatus::kFailed, {200, 0, 0, 0, 0, 0});
  Calibration(kMachine, JobStatus::kRunning, {250, 0, 0, 0, 0, 0});
  Calibration(kMachine, JobStatus::kDone, {300, 0, 0, 0, 0, 0}, {{"condition_number", nullptr}});
  Calibration(kMachine, JobStatus::kDone, {400, 0, 0, 0, 0, 0}, json::object(), "discovery");
  ASSERT_EQ(svc_->studies().Job(JobId(newest.value() + 4))["verdict"], "failed");

  const json v = Audit(
      kMachine,
      json::array({Rule("strut_offset_max_um", 8, 10), Rule("strut_offset_max_um", 5, 10),
                   Rule("strut_offset_max_um", 2, 7), Rule("strut_offset_change_max_um", 10, 12)}));
  EXPECT_EQ(v["level"], 3);
  ASSERT_EQ(v["checked"].size(), 4u);
  const json& ok = v["checked"][0];
  EXPECT_EQ(ok["status"], "ok");
  EXPECT_EQ(ok["level"], 1);
  EXPECT_EQ(ok["value"], 7.5);
  EXPECT_EQ(ok["job_id"], nlohmann::json(newest));
  EXPECT_FALSE(ok.contains("measurement_id"));
  EXPECT_EQ(ok["measured_at"], FinishedAt(newest));

  ASSERT_EQ(v["findings"].size(), 3u);
  const json& warn = v["findings"][0];
  EXPECT_EQ(warn["rule"], 1);
  EXPECT_EQ(warn["kind"], "calibration");
  EXPECT_EQ(warn["level"], 2);
  EXPECT_EQ(warn["value"], 7.5);
  EXPECT_EQ(warn["limit"], 5.0);
  EXPECT_EQ(warn["job_id"], nlohmann::json(newest));
  EXPECT_FALSE(warn.contains("measurement_id"));
  EXPECT_EQ(warn["measured_at"], FinishedAt(newest));
  EXPECT_EQ(warn["message"],
            "calibration strut_offset_max_um 7.5, above the warn limit 5 "
            "(calibration job " +
                to_string(newest) + ")");
  const json& stop = v["findings"][1];
  EXPECT_EQ(stop["rule"], 2);
  EXPECT_EQ(stop["level"], 3);
  EXPECT_EQ(stop["value"], 7.5);
  EXPECT_EQ(stop["limit"], 7.0);
  EXPECT_EQ(stop["job_id"], nlohmann::json(newest));
  // The largest |Δ| over the struts from the calibration before: |-7.5 − 5| = 12.5.
  const json& change = v["findings"][2];
  EXPECT_EQ(change["metric"], "strut_offset_change_max_um");
  EXPECT_EQ(change["level"], 3);
  EXPECT_EQ(change["value"], 12.5);
  EXPECT_EQ(change["limit"], 12.0);
  EXPECT_EQ(change["job_id"], nlohmann::json(newest));
  EXPECT_NE(older, newest);

  // The listed verdict (GET /api/v1/audits) carries the same evidence.
  AuditVerdictFilter f;
  f.machine_id = kMachine;
  EXPECT_EQ(ListAccuracyAudits(*svc_, f)["audits"][0]["findings"], v["findings"]);
}

TEST_F(CalibrationAudits, WithoutCalibrationsTheRulesFindNoValue) {
  Calibration("hexa-8", JobStatus::kDone, {100, 0, 0, 0, 0, 0});
  Calibration(kMachine, JobStatus::kFailed, {200, 0, 0, 0, 0, 0});
  const json none = Audit(kMachine, json::array({Rule("strut_offset_max_um", 5, 10),
                                                 Rule("strut_offset_change_max_um", 5, 10)}));
  EXPECT_EQ(none["level"], 1);
  EXPECT_TRUE(none["findings"].empty());
  for (const auto& c : none["checked"]) {
    EXPECT_EQ(c["status"], "not evaluated");
    EXPECT_EQ(c["reason"], "no result of this metric yet");
  }
  // One calibration: its offsets, but no change (nothing before it).
  const auto only = Calibration(kMachine, JobStatus::kDone, {0, 0, -11, 0, 0, 0});
  const json one = Audit(kMachine, json::array({Rule("strut_offset_max_um", 5, 10),
                                                Rule("strut_offset_change_max_um", 5, 10)}));
  EXPECT_EQ(one["level"], 3);
  EXPECT_EQ(one["findings"][0]["value"], 11.0);
  EXPECT_EQ(one["findings"][0]["job_id"], nlohmann::json(only));
  EXPECT_EQ(one["checked"][1]["status"], "not evaluated");
  EXPECT_EQ(one["checked"][1]["reason"], "no result of this metric yet");
}

TEST_F(CalibrationAudits, TrendRulesCompareWithTheCalibrationThePreviousAuditSaw) {
  const auto first = Calibration(kMachine, JobStatus::kDone, {1, 2, 3, 4, 5, -7.5});
  const json rules = json::array({{{"kind", "calibration"},
                                   {"metric", "strut_offset_max_um"},
                                   {"change", "previous_audit"},
                                   {"warn", 1}}});
  const json a = Audit(kMachine, rules);
  EXPECT_EQ(a["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(a["checked"][0]["value"], 7.5);
  EXPECT_EQ(a["checked"][0]["job_id"], nlohmann::json(first));
  const auto second = Calibration(kMachine, JobStatus::kDone, {9, 2, 3, 4, 5, -7.5});
  const json b = RunAccuracyAudit(*svc_, kMachine, "manual", 1795749180);
  EXPECT_EQ(b["level"], 2);
  const json& f = b["findings"][0];
  EXPECT_EQ(f["value"], 1.5);
  EXPECT_EQ(f["newest_value"], 9.0);
  EXPECT_EQ(f["job_id"], nlohmann::json(second));
  EXPECT_EQ(f["reference_value"], 7.5);
  EXPECT_EQ(f["reference_job_id"], nlohmann::json(first));
  EXPECT_FALSE(f.contains("reference_measurement_id"));
  EXPECT_EQ(f["reference_measured_at"], FinishedAt(first));

  // Over days: the reference is the newest calibration finished at or before now − days.
  const auto finished = UnixSecondsFromIso(FinishedAt(second)).value();
  const json days = json::array({{{"kind", "calibration"},
                                  {"metric", "strut_offset_max_um"},
                                  {"change", "days"},
                                  {"days", 1},
                                  {"warn", 1}}});
  const json early = Audit(kMachine, days, finished + 3600);
  EXPECT_EQ(early["checked"][0]["status"], "not evaluated");
  EXPECT_EQ(early["checked"][0]["reason"],
            "no calibration at or before " + IsoFromUnixSeconds(finished + 3600 - 86400));
  const json later = Audit(kMachine, days, finished + 86400);
  EXPECT_EQ(later["checked"][0]["status"], "ok");
  EXPECT_EQ(later["checked"][0]["value"], 0.0);
  EXPECT_EQ(later["checked"][0]["reference_job_id"], nlohmann::json(second));
}

TEST_F(CalibrationAudits, TheTrendOfACalibrationMetricListsItsJobs) {
  // A machine the fleet knows (it has a measurement) with two calibrations.
  const auto f = DemoDbbFiles().at(0);
  const auto machine =
      svc_->storage().GetMeasurement(svc_->measurements().Upload(f.bytes, f.name).id)->machine_id;
  const auto a = Calibration(machine, JobStatus::kDone, {1, -2, 3, -4, 5, -6});
  Calibration(machine, JobStatus::kFailed, {200, 0, 0, 0, 0, 0});
  const auto b = Calibration(machine, JobStatus::kDone, {2, -3, 1, 0.5, -7.5, 4});
  const json t = Trends(*svc_, machine, "strut_offset_max_um");
  EXPECT_EQ(t["kind"], "calibration");
  EXPECT_EQ(t["unit"], "µm");
  ASSERT_EQ(t["points"].size(), 2u);
  EXPECT_EQ(t["points"][0], json({{"measured_at", FinishedAt(a)}, {"value", 6.0}, {"job_id", a}}));
  EXPECT_EQ(t["points"][1], json({{"measured_at", FinishedAt(b)}, {"value", 7.5}, {"job_id", b}}));
  const json change = Trends(*svc_, machine, "strut_offset_change_max_um");
  ASSERT_EQ(change["points"].size(), 1u);
  EXPECT_EQ(change["points"][0]["value"], 12.5);
  EXPECT_EQ(change["points"][0]["job_id"], nlohmann::json(b));
}

}  // namespace
}  // namespace km::server::test
