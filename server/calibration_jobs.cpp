// Hexapod calibration studies submitted through the API run as background jobs.
#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"
#include "ingest/machine_json.h"
#include "server/hexapod_report.h"
#include "server/request_json.h"
#include "server/service.h"

namespace km::server {

namespace req = km::server::request;

std::int64_t Service::SubmitCalibration(const nlohmann::json& request) {
  if (!request.is_object()) throw InvalidInput("request", 0, "", "the body must be a JSON object");
  if (!request.contains("machine") || !request["machine"].is_object()) {
    throw InvalidInput("request", 0, "machine",
                       "the hexapod machine definition (contract §2) is required as an object");
  }
  auto study = std::make_shared<CalibrationStudy>();
  study->machine = ingest::ParseHexapodMachineJson(request["machine"].dump(), "request.machine");
  if (!request.contains("measurement_ids") || !request["measurement_ids"].is_array() ||
      request["measurement_ids"].empty()) {
    throw InvalidInput("request", 0, "measurement_ids", "a non-empty list of DBB measurement ids");
  }
  for (const auto& v : request["measurement_ids"]) {
    if (!v.is_number_integer()) {
      throw InvalidInput("request", 0, "measurement_ids", "ids must be whole numbers");
    }
    const std::int64_t id = v.get<std::int64_t>();
    study->tests.push_back(LoadDbb(id));
    study->names.push_back("measurement " + std::to_string(id));
  }
  if (request.contains("method")) {
    if (!request["method"].is_string()) {
      throw InvalidInput("request", 0, "method", "absolute or centre-corrected");
    }
    study->method = ParseCalibrationMethod(request["method"].get<std::string>(), "method");
  }
  study->reduction_min_tests =
      static_cast<int>(req::WholeNumber(request, "reduction_study_min_tests", 1, 1000, 0));
  study->max_samples_per_test =
      static_cast<int>(req::WholeNumber(request, "max_samples_per_test", 0, 10'000'000, 0));
  // The checks that need no solve (tool length, fixed balls) happen now, not in the job.
  for (std::size_t i = 0; i < study->tests.size(); ++i) {
    if (!study->tests[i].tool_length_mm) {
      throw InvalidInput(study->names[i], 0, "tool_length_mm",
                         "hexapod calibration needs the tool length");
    }
  }
  nlohmann::json stored = request;
  stored.erase("machine");
  stored["machine_id"] = study->machine.machine_id;
  return jobs_->Submit("hexapod_calibration", stored, [study](const JobQueue::Progress& p) {
    auto outcome = RunCalibrationStudy(*study, p);
    outcome.report["calibrated_machine"] =
        nlohmann::json::parse(ingest::WriteMachineJson(outcome.calibrated));
    return outcome.report;
  });
}

nlohmann::json Service::Job(std::int64_t id) {
  const auto job = storage_->GetJob(id);
  if (!job) throw NotFound("job " + std::to_string(id) + " does not exist");
  return JobJson(*job);
}

nlohmann::json Service::Jobs(std::int64_t limit) {
  nlohmann::json items = nlohmann::json::array();
  for (const auto& j : storage_->ListJobs(limit)) {
    nlohmann::json x = JobJson(j);
    x.erase("result");  // the list stays small; GET /api/v1/jobs/{id} has the result
    items.push_back(x);
  }
  return {{"items", items}};
}

}  // namespace km::server
