// Model-gap discovery studies submitted through the API run as background jobs, on the same
// queue and with the same request checks as calibration studies (calibration_jobs.cpp): the
// request is checked from the stored records alone, and the queued job keeps the ids and reads
// each test once when it runs. The discovery's judge is registered beside its runner.
#include <cstdint>
#include <memory>
#include <optional>

#include "analysis/core/errors.h"
#include "analysis/discovery/engine.h"
#include "ingest/machine_json.h"
#include "server/base/errors.h"
#include "server/jobs/study_service.h"
#include "usecases/discovery_report.h"

namespace km::server {

// What a discovery job needs to run: the request, checked, with ids instead of tests.
struct DiscoveryPlan {
  std::optional<ingest::MachineDefinition> machine;  // none: the serial study
  std::vector<std::int64_t> ids;
  int max_samples_per_test = 0;
};

std::shared_ptr<DiscoveryPlan> StudyService::ResolveDiscovery(const DiscoveryRequest& request,
                                                              std::int64_t& version) {
  auto plan = std::make_shared<DiscoveryPlan>();
  version = 0;
  if (request.model) plan->machine = models_.RequestedMachine(*request.model, version);
  plan->max_samples_per_test = request.max_samples_per_test.value_or(0);
  plan->ids = request.measurement_ids;
  return plan;
}

std::shared_ptr<DiscoveryPlan> StudyService::CheckDiscovery(const DiscoveryRequest& request,
                                                            std::int64_t& version) {
  auto plan = ResolveDiscovery(request, version);
  const bool hexapod = plan->machine && plan->machine->kind == "hexapod";
  plan->ids = CheckedDbbIds(request.measurement_ids, "discovery study", hexapod, false);
  return plan;
}

JobId StudyService::SubmitDiscovery(const DiscoveryRequest& request,
                                    std::optional<TokenId> owner_token_id) {
  std::int64_t version = 0;
  const auto plan = CheckDiscovery(request, version);
  // Shown and run: the request with the stored model's version it was checked against.
  nlohmann::json stored = request.ToJson();
  if (plan->machine) stored["machine_version"] = version;
  return queue_.Submit(kDiscoveryJob, stored, stored, owner_token_id);
}

// The job runs its stored plan as it was checked when queued (the stored model's version is
// fixed) and reads each test once.
JobOutput StudyService::RunDiscoveryJob(const nlohmann::json& plan_json, const ProgressFn& p) {
  std::int64_t version = 0;
  const auto plan = ResolveDiscovery(DiscoveryRequest::Parse(plan_json), version);
  usecases::DiscoveryStudy study;
  study.machine = plan->machine;
  study.max_samples_per_test = plan->max_samples_per_test;
  if (p) p(0.0, "reading the DBB tests");
  study.tests.reserve(plan->ids.size());
  study.names.reserve(plan->ids.size());
  for (const std::int64_t id : plan->ids) {
    study.tests.push_back(measurements_.LoadDbb(MeasurementId(id)));
    study.names.push_back("measurement " + std::to_string(id));
  }
  usecases::DiscoveryOutcome outcome = usecases::RunDiscoveryStudy(study, p);
  JobOutput out;
  out.result = outcome.report.is_object() ? std::move(outcome.report)
                                          : nlohmann::json{{"report", std::move(outcome.report)}};
  // The updated machine document, kept as written (POST /api/v1/jobs/{id}/save-machine stores
  // it unchanged) and shown in the result.
  if (outcome.updated_machine) {
    out.machine_document = ingest::WriteMachineJson(*outcome.updated_machine);
    out.result["updated_machine"] = nlohmann::json::parse(out.machine_document);
  }
  return out;
}

void JudgeDiscoveryResult(const nlohmann::json& r, JobFindings& out) {
  const std::string verdict = r.value("verdict", std::string());
  const std::string stop = r.value("stop_reason", std::string());
  const auto parsed = discovery::ParseVerdict(verdict);
  if (parsed == discovery::Verdict::kModelMisfit) {
    out.Warn("model misfit: the tests show an error no candidate effect describes" +
             (stop.empty() ? std::string() : " (stopped because " + stop + ")"));
  } else if (parsed != discovery::Verdict::kComplete) {
    out.Warn("no clear verdict from the study" +
             (verdict.empty() ? std::string() : " ('" + verdict + "')"));
  }
  // The final fit's condition number mixes parameters of different units (kinematic µm, effect
  // coefficients): no bound applies to it, but it must be a number.
  JudgeConditionNumber(r, 0.0, out);
}

}  // namespace km::server
