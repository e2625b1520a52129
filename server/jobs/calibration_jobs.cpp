// Hexapod calibration studies submitted through the API run as background jobs. A request is
// checked completely before it is queued, from the stored records alone (no measurement file is
// read): the number of tests and of their samples is bounded, every id is listed once and names
// a stored DBB test with a tool length. The queued job keeps the ids, not the tests: it reads
// each test once, when it runs.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "ingest/machine_json.h"
#include "server/base/errors.h"
#include "server/jobs/study_service.h"
#include "usecases/calibration_study.h"

namespace km::server {

// What a calibration job needs to run: the request, checked, with ids instead of tests.
struct CalibrationPlan {
  ingest::MachineDefinition machine;
  std::vector<std::int64_t> ids;
  std::optional<hexapod::CalibrationMethod> method;
  int max_samples_per_test = 0;
  int reduction_min_tests = 0;
  std::vector<std::string> effects;  // fitted with the kinematics (docs/hexapod-effects.md)
};

namespace {

std::string TestName(std::int64_t id) {
  return "measurement " + std::to_string(id);
}

// The tests of a study are of one machine: a model is calibrated (or its gaps found) from the
// tests of the machine it describes, not from another machine's.
void RequireOneMachine(const std::vector<std::int64_t>& ids,
                       const std::vector<std::string>& machines, const std::string& study) {
  for (std::size_t i = 1; i < machines.size(); ++i) {
    if (machines[i] != machines[0]) {
      throw InvalidInput("request", 0, "measurement_ids",
                         "measurement " + std::to_string(ids[0]) + " is of machine '" +
                             machines[0] + "', measurement " + std::to_string(ids[i]) + " of '" +
                             machines[i] + "'; a " + study + " takes the DBB tests of one machine");
    }
  }
}

// Effects fitted with the kinematics (named, or the stored model's own) leave no room for the
// reduction study, which recalibrates the plain kinematics only.
void RequireReductionWithoutEffects(const CalibrationPlan& plan) {
  if (plan.reduction_min_tests == 0) return;
  if (!plan.effects.empty()) {
    throw InvalidInput("request", 0, "reduction_study_min_tests",
                       "the reduction study is available for the plain calibration only; the "
                       "request names effects to fit");
  }
  if (!plan.machine.effects.empty()) {
    throw InvalidInput(
        "request", 0, "reduction_study_min_tests",
        "the reduction study is available for the plain calibration only; machine '" +
            plan.machine.machine_id + "' has effects of its own");
  }
}

}  // namespace

std::vector<std::int64_t> StudyService::CheckedDbbIds(const std::vector<std::int64_t>& ids,
                                                      const std::string& study,
                                                      bool need_tool_length, bool need_fixed_ball) {
  if (ids.size() > options_.max_calibration_tests) {
    throw InvalidInput("request", 0, "measurement_ids",
                       std::to_string(ids.size()) + " ids; a " + study + " takes at most " +
                           std::to_string(options_.max_calibration_tests) + " DBB tests");
  }
  std::map<std::int64_t, std::size_t> position;  // id -> 1-based position in the list
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const auto [it, fresh] = position.emplace(ids[i], i + 1);
    if (!fresh) {
      throw InvalidInput("request", 0, "measurement_ids",
                         "measurement " + std::to_string(ids[i]) + " is listed twice (entries " +
                             std::to_string(it->second) + " and " + std::to_string(i + 1) +
                             "); list each DBB test once (duplicates are refused, not merged)");
    }
  }
  // Every test from its stored record (no file is read now): it exists, is a DBB test, and has
  // what the study needs without a solve (tool length; the fixed ball when the method is
  // absolute). The samples of all tests together are bounded: the job holds them all.
  std::size_t samples = 0;
  std::vector<std::string> machines;
  for (const std::int64_t id : ids) {
    const auto rec = measurement_store_.GetMeasurement(MeasurementId(id));
    if (!rec) throw NotFound("measurement " + std::to_string(id) + " does not exist");
    if (rec->kind != "dbb") {
      throw InvalidInput("request", 0, "measurement_ids",
                         "measurement " + std::to_string(id) + " is not a DBB test");
    }
    const auto meta = ingest::ParseJsonTextOrDiscarded(rec->metadata_json);
    const auto has = [&](const char* key) { return meta.is_object() && meta.contains(key); };
    if (need_tool_length && !has("tool_length_mm")) {
      throw InvalidInput(TestName(id), 0, "tool_length_mm",
                         "hexapod calibration needs the tool length");
    }
    if (need_fixed_ball && !has("fixed_ball_mm")) {
      throw InvalidInput(TestName(id), 0, "fixed_ball_mm",
                         "absolute calibration needs the measured fixed-ball position");
    }
    samples += static_cast<std::size_t>(std::max<std::int64_t>(rec->sample_count, 0));
    machines.push_back(rec->machine_id);
  }
  RequireOneMachine(ids, machines, study);
  if (samples > options_.max_calibration_samples) {
    throw InvalidInput("request", 0, "measurement_ids",
                       "the " + std::to_string(ids.size()) + " DBB tests hold " +
                           std::to_string(samples) + " samples in all; a " + study +
                           " takes at most " + std::to_string(options_.max_calibration_samples));
  }
  return ids;
}

std::shared_ptr<CalibrationPlan> StudyService::ResolveCalibration(const CalibrationRequest& request,
                                                                  std::int64_t& stored_version) {
  auto plan = std::make_shared<CalibrationPlan>();
  stored_version = 0;
  if (request.machine) {
    plan->machine = ingest::ParseHexapodMachineJson(request.machine->dump(), "request.machine");
  } else {
    plan->machine = models_.RequestedMachine(*request.model, stored_version);
    if (plan->machine.kind != "hexapod") {
      throw InvalidInput("request", 0, "machine_id",
                         "stored model '" + plan->machine.machine_id + "' version " +
                             std::to_string(stored_version) + " is not a hexapod");
    }
  }
  plan->method = request.method;
  plan->reduction_min_tests = request.reduction_study_min_tests.value_or(0);
  plan->effects = request.effects;
  plan->max_samples_per_test = request.max_samples_per_test.value_or(0);
  plan->ids = request.measurement_ids;
  return plan;
}

std::shared_ptr<CalibrationPlan> StudyService::CheckCalibration(const CalibrationRequest& request,
                                                                std::int64_t& stored_version) {
  auto plan = ResolveCalibration(request, stored_version);
  RequireReductionWithoutEffects(*plan);
  plan->ids = CheckedDbbIds(request.measurement_ids, "calibration study", true,
                            plan->method == hexapod::CalibrationMethod::kAbsolute);
  return plan;
}

JobId StudyService::SubmitCalibration(const CalibrationRequest& request,
                                      std::optional<TokenId> owner_token_id) {
  std::int64_t stored_version = 0;
  const auto plan = CheckCalibration(request, stored_version);
  // The plan any instance runs: the request, with the stored model's version it was checked
  // against (versions are never changed). Shown: the same without the machine definition.
  nlohmann::json run = request.ToJson();
  if (stored_version > 0) run["machine_version"] = stored_version;
  nlohmann::json shown = run;
  shown.erase("machine");
  shown["machine_id"] = plan->machine.machine_id;
  return queue_.Submit(kCalibrationJob, shown, run, owner_token_id);
}

// The job runs its stored plan as it was checked when queued (the stored model's version is
// fixed; a test removed since then fails the job naming it) and reads each test once.
JobOutput StudyService::RunCalibrationJob(const nlohmann::json& plan_json, const ProgressFn& p) {
  std::int64_t version = 0;
  const auto plan = ResolveCalibration(CalibrationRequest::Parse(plan_json), version);
  usecases::CalibrationStudy study;
  study.machine = plan->machine;
  study.method = plan->method;
  study.max_samples_per_test = plan->max_samples_per_test;
  study.reduction_min_tests = plan->reduction_min_tests;
  study.effects = plan->effects;
  if (p) p(0.0, "reading the DBB tests");
  study.tests.reserve(plan->ids.size());
  study.names.reserve(plan->ids.size());
  for (const std::int64_t id : plan->ids) {
    study.tests.push_back(measurements_.LoadDbb(MeasurementId(id)));
    study.names.push_back(TestName(id));
  }
  auto outcome = usecases::RunCalibrationStudy(study, p);
  // The calibrated machine document, kept as written (POST /api/v1/jobs/{id}/save-machine stores
  // it unchanged) and shown in the result.
  JobOutput out;
  out.machine_document = ingest::WriteMachineJson(outcome.calibrated);
  out.result = std::move(outcome.report);
  out.result["calibrated_machine"] = nlohmann::json::parse(out.machine_document);
  return out;
}

namespace {

// The largest value of a nested array of numbers (parameter_uncertainty_um's groups); `bad`
// when a value is missing or not finite (null in the JSON).
void LargestOf(const nlohmann::json& j, double& largest, bool& bad) {
  if (j.is_number()) {
    const double v = j.get<double>();
    if (!std::isfinite(v)) bad = true;
    if (v > largest) largest = v;
  } else if (j.is_array() || j.is_object()) {
    for (const auto& x : j) LargestOf(x, largest, bad);
  } else if (j.is_null()) {
    bad = true;
  }
}

void JudgeParameterUncertainty(const nlohmann::json& r, JobFindings& out) {
  if (!r.contains("parameter_uncertainty_um")) return;
  double largest = 0.0;
  bool bad = false;
  LargestOf(r["parameter_uncertainty_um"], largest, bad);
  if (bad) {
    out.Fail("under-determined: a parameter uncertainty is not finite");
  } else if (largest > kUndeterminedAboveUm) {
    out.Warn("under-determined: parameter uncertainty up to ±" + VerdictNumber(largest) +
             " µm (above ±" + VerdictNumber(kUndeterminedAboveUm) +
             " µm): the tests do not determine the parameters; add tests in other poses");
  }
}

// Parameters fixed beyond the method's gauge (none for absolute; the 6 rigid motions of the base
// for centre-corrected, [PM-600 report] §2.3) are ones these tests cannot identify.
void JudgeFixedParameters(const nlohmann::json& r, JobFindings& out) {
  const auto fixed = r.value("fixed_parameters", nlohmann::json::array());
  const std::size_t gauge = r.value("method", std::string()) == "centre_corrected" ? 6 : 0;
  if (!fixed.is_array() || fixed.size() <= gauge) return;
  out.Warn("under-determined: " + std::to_string(fixed.size()) +
           " parameters cannot be identified from these tests and were fixed (" +
           (gauge == 0 ? std::string("an absolute calibration fixes none")
                       : "a centre-corrected one fixes the " + std::to_string(gauge) +
                             " rigid motions of the base") +
           ")");
}

}  // namespace

void JudgeCalibrationResult(const nlohmann::json& r, JobFindings& out) {
  if (r.contains("converged") && r["converged"].is_boolean() && !r["converged"].get<bool>()) {
    const std::string it =
        r.contains("iterations") && r["iterations"].is_number_integer()
            ? " after " + std::to_string(r["iterations"].get<long long>()) + " iterations"
            : "";
    out.Warn("not converged: the solver stopped" + it + " before the parameters settled");
  }
  JudgeConditionNumber(r, kIllConditionedAbove, out);
  JudgeParameterUncertainty(r, out);
  JudgeFixedParameters(r, out);
}

nlohmann::json StudyService::Job(JobId id) {
  const auto job = job_store_.GetJob(id);
  if (!job) throw NotFound("job " + to_string(id) + " does not exist");
  std::map<std::int64_t, std::string> machine_of;
  return AnsweredJob(*job, machine_of);
}

nlohmann::json StudyService::CancelJob(JobId id, const JobCanceller& by) {
  const auto job = job_store_.GetJob(id);
  const std::string name = "job " + to_string(id);
  if (!job) throw NotFound(name + " does not exist");
  if (!by.admin && (!job->owner_token_id || job->owner_token_id != by.token_id)) {
    throw Forbidden(name + " was submitted by another token; only its owner or an admin may " +
                    "cancel it");
  }
  const std::string reason = "cancelled by token '" + by.token_name + "' (id " +
                             std::to_string(ValueOrZero(by.token_id)) + ")";
  if (!queue_.Cancel(id, reason)) {
    const auto now = job_store_.GetJob(id);
    throw Conflict(name + " is " +
                   (now ? std::string(ToString(now->status)) : std::string("gone")) +
                   " already; only a queued or running job can be cancelled");
  }
  return Job(id);
}

nlohmann::json StudyService::Jobs(std::int64_t limit) {
  nlohmann::json items = nlohmann::json::array();
  std::map<std::int64_t, std::string> machine_of;  // measurement id → machine, looked up once
  for (const auto& j : job_store_.ListJobs(limit)) {
    nlohmann::json x = AnsweredJob(j, machine_of);
    x.erase("result");  // the list stays small; GET /api/v1/jobs/{id} has the result
    items.push_back(x);
  }
  return {{"items", items}};
}

}  // namespace km::server
