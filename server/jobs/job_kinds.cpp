#include "server/jobs/job_kinds.h"

#include <cmath>
#include <cstdio>

#include "ingest/json_text.h"

namespace km::server {

std::string VerdictNumber(double v) {
  char buf[64];
  if (std::fabs(v) >= 100.0) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%.3g", v);
  }
  return buf;
}

void JudgeConditionNumber(const nlohmann::json& r, double bound, JobFindings& out) {
  if (!r.contains("condition_number")) return;
  const auto& c = r["condition_number"];
  if (!c.is_number() || !std::isfinite(c.get<double>())) {
    out.Fail(
        "ill-conditioned: the condition number is not finite (the tests do not determine "
        "every parameter)");
    return;
  }
  const double cond = c.get<double>();
  if (bound > 0 && cond > bound) {
    out.Warn("ill-conditioned: condition number " + VerdictNumber(cond) + " (above " +
             VerdictNumber(bound) + "): the tests do not tell the parameters apart");
  }
}

JobVerdict JudgeJobOutcome(const std::function<void(const nlohmann::json&, JobFindings&)>& judge,
                           JobStatus status, const nlohmann::json& result,
                           const std::string& error) {
  if (status == JobStatus::kFailed) return {"failed", {error.empty() ? "the job failed" : error}};
  if (status != JobStatus::kDone) return {};
  JobFindings f;
  if (!result.is_object()) {
    f.Fail("the job stored no result");
  } else if (judge) {
    judge(result, f);
  }
  if (f.reasons.empty()) return {"ok", {}};
  return {f.failed ? "failed" : "warning", f.reasons};
}

const JobKind* JobKinds::Find(const std::string& name) const {
  const auto it = kinds_.find(name);
  return it == kinds_.end() ? nullptr : &it->second;
}

namespace {

nlohmann::json StoredResult(const JobRecord& job) {
  return job.result_json.empty() ? nlohmann::json()
                                 : ingest::ParseJsonText(job.result_json, "stored document");
}

}  // namespace

JobVerdict JobKinds::Verdict(const JobRecord& job) const {
  return Verdict(job, StoredResult(job));
}

JobVerdict JobKinds::Verdict(const JobRecord& job, const nlohmann::json& result) const {
  const JobKind* kind = Find(job.kind);
  return JudgeJobOutcome(kind ? kind->judge : nullptr, job.status, result, job.error);
}

nlohmann::json JobKinds::Json(const JobRecord& job) const {
  nlohmann::json j;
  j["id"] = job.id;
  j["kind"] = job.kind;
  j["status"] = ToString(job.status);
  j["progress"] = job.progress;
  j["stage"] = job.stage;
  j["created_at"] = job.created_at;
  j["updated_at"] = job.updated_at;
  j["request"] = job.request_json.empty()
                     ? nlohmann::json(nullptr)
                     : ingest::ParseJsonText(job.request_json, "stored document");
  const nlohmann::json result = StoredResult(job);
  if (!job.result_json.empty()) j["result"] = result;
  if (!job.error.empty()) j["error"] = job.error;
  // The instance running the job, or the one that finished it; how often it was started.
  j["instance"] =
      job.lease_owner.empty() ? nlohmann::json(nullptr) : nlohmann::json(job.lease_owner);
  j["attempts"] = job.attempts;
  j["owner_token_id"] = IdOrNull(job.owner_token_id);
  const JobVerdict v = Verdict(job, result);
  j["verdict"] = v.verdict.empty() ? nlohmann::json(nullptr) : nlohmann::json(v.verdict);
  j["verdict_reasons"] = v.reasons;
  return j;
}

}  // namespace km::server
