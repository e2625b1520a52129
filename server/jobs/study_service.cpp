// The study service: its job queue and runners, the jobs of a machine, and saving the machine a
// job produced as the next version of its model.
#include "server/jobs/study_service.h"

#include <map>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "server/base/errors.h"

namespace km::server {

StudyService::StudyService(MeasurementStore& measurement_store, JobStore& job_store,
                           MeasurementService& measurements, ModelService& models,
                           StudyOptions options)
    : measurement_store_(measurement_store),
      job_store_(job_store),
      measurements_(measurements),
      models_(models),
      options_(options),
      queue_(job_store, kinds_, options.jobs) {
  kinds_.Add(kCalibrationJob, {[this](const nlohmann::json& plan, const ProgressFn& p) {
                                 return RunCalibrationJob(plan, p);
                               },
                               JudgeCalibrationResult});
  kinds_.Add(kDiscoveryJob, {[this](const nlohmann::json& plan, const ProgressFn& p) {
                               return RunDiscoveryJob(plan, p);
                             },
                             JudgeDiscoveryResult});
  queue_.Start();
}

std::string StudyService::TestsMachine(const nlohmann::json& req,
                                       std::map<std::int64_t, std::string>& machine_of) {
  if (!req.is_object() || !req.contains("measurement_ids") || !req["measurement_ids"].is_array() ||
      req["measurement_ids"].empty() || !req["measurement_ids"][0].is_number_integer()) {
    return "";
  }
  const auto id = req["measurement_ids"][0].get<std::int64_t>();
  auto it = machine_of.find(id);
  if (it == machine_of.end()) {
    const auto rec = measurement_store_.GetMeasurement(MeasurementId(id));
    it = machine_of.emplace(id, rec ? rec->machine_id : std::string()).first;
  }
  return it->second;
}

nlohmann::json StudyService::AnsweredJob(const JobRecord& job,
                                         std::map<std::int64_t, std::string>& machine_of) {
  nlohmann::json j = kinds_.Json(job);
  const nlohmann::json req = j.value("request", nlohmann::json());
  const std::string machine =
      req.is_object() && req.contains("machine_id") && req["machine_id"].is_string()
          ? req["machine_id"].get<std::string>()
          : TestsMachine(req, machine_of);
  j["machine_id"] = machine.empty() ? nlohmann::json(nullptr) : nlohmann::json(machine);
  return j;
}

nlohmann::json StudyService::JobsOfMachine(const std::string& machine_id, std::int64_t limit,
                                           std::int64_t scan) {
  std::map<std::int64_t, std::string> machine_of;  // measurement id → machine, looked up once
  nlohmann::json items = nlohmann::json::array();
  for (const auto& j : job_store_.ListJobs(scan)) {
    if (static_cast<std::int64_t>(items.size()) >= limit) break;
    // The request decides; only the jobs of the machine are turned into JSON (with the verdict).
    const auto req = ingest::ParseJsonTextOrDiscarded(j.request_json);
    const bool mine = (req.is_object() && req.value("machine_id", std::string()) == machine_id) ||
                      TestsMachine(req, machine_of) == machine_id;
    if (!mine) continue;
    nlohmann::json x = AnsweredJob(j, machine_of);
    x.erase("result");  // as Jobs: GET /api/v1/jobs/{id} has the result
    items.push_back(std::move(x));
  }
  return {{"items", items}};
}

MachineModelStored StudyService::SaveJobMachine(JobId job_id, const std::string& note) {
  const auto job = job_store_.GetJob(job_id);
  if (!job) throw NotFound("job " + to_string(job_id) + " does not exist");
  const std::string name = "job " + to_string(job_id);
  std::string key, source;
  if (job->kind == kCalibrationJob) {
    key = "calibrated_machine";
    source = "calibration " + name;
  } else if (job->kind == kDiscoveryJob) {
    key = "updated_machine";
    source = "discovery " + name;
  } else {
    throw Conflict(name + " (" + job->kind + ") does not produce a machine definition");
  }
  if (job->status != JobStatus::kDone) {
    throw Conflict(name + " is " + ToString(job->status) +
                   (job->status == JobStatus::kFailed
                        ? "; it has no machine to save"
                        : "; its machine can be saved once it is done"));
  }
  // The document exactly as the job's machine writer produced it.
  if (!job->machine_document.empty()) {
    return models_.StoreMachineModel(job->machine_document, source, note, name + " " + key);
  }
  // A job finished before its document was kept: the machine in its result, written as the
  // machine writer writes (indent 2, closing newline).
  const auto result = ingest::ParseJsonTextOrDiscarded(job->result_json);
  if (!result.is_object() || !result.contains(key) || !result[key].is_object()) {
    throw Conflict(name + " produced no machine to save (its result has no " + key + ")");
  }
  return models_.StoreMachineModel(result[key].dump(2) + "\n", source, note, name + " " + key);
}

}  // namespace km::server
