#include "server/audits/calibration_runs.h"

#include <algorithm>

#include "ingest/json_text.h"
#include "server/base/time_util.h"
#include "server/jobs/study_service.h"

namespace km::server {

using nlohmann::json;

std::vector<CalibrationRun> MachineCalibrations(AuditSource& service,
                                                const std::string& machine_id) {
  std::vector<CalibrationRun> runs;
  for (const auto& j : service.job_store().ListJobs(kCalibrationJobScan)) {
    if (j.kind != kCalibrationJob || j.status != JobStatus::kDone) continue;
    const json request = ingest::ParseJsonTextOrDiscarded(j.request_json);
    if (!request.is_object() || !request.contains("machine_id") ||
        request["machine_id"] != machine_id) {
      continue;
    }
    json result = ingest::ParseJsonTextOrDiscarded(j.result_json);
    if (!result.is_object() || service.JobVerdictOf(j, result).verdict == "failed") {
      continue;
    }
    CalibrationRun run;
    run.job_id = j.id;
    run.finished_at = j.updated_at;
    run.at = UnixSecondsFromIso(j.updated_at).value_or(0);
    run.result = std::move(result);
    runs.push_back(std::move(run));
  }
  // Newest first by when they finished (jobs are listed by when they were queued).
  std::stable_sort(runs.begin(), runs.end(), [](const CalibrationRun& a, const CalibrationRun& b) {
    return a.at != b.at ? a.at > b.at : a.job_id > b.job_id;
  });
  for (std::size_t i = 0; i + 1 < runs.size(); ++i) runs[i].previous = runs[i + 1].result;
  return runs;
}

std::optional<double> CalibrationMetricValue(const AuditMetric& metric, const CalibrationRun& run) {
  if (metric.analysis == "hexapod_calibration-pair") {
    if (run.previous.is_null()) return std::nullopt;
    return ExtractAuditMetric(metric, json{{"newest", run.result}, {"previous", run.previous}});
  }
  return ExtractAuditMetric(metric, run.result);
}

}  // namespace km::server
