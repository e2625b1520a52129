#include "server/jobs.h"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

// One storage update of the worker. A storage error (a full disk, a locked or damaged
// database) must not end the process: it is reported on stderr with the job id and returned.
std::optional<std::string> TryUpdate(Storage& storage, const JobRecord& job, const char* what) {
  std::string error;
  try {
    storage.UpdateJob(job);
    return std::nullopt;
  } catch (const std::exception& e) {
    error = e.what();
  } catch (...) {
    error = "unknown storage error";
  }
  try {
    std::cerr << "kinemetricd: job " << job.id << ": could not store " << what << " (" << job.status
              << "): " << error << std::endl;
  } catch (...) {  // NOLINT(bugprone-empty-catch): nothing is left to report to
  }
  return error;
}

}  // namespace

JobQueue::JobQueue(Storage& storage, std::size_t max_queued)
    : storage_(storage), max_queued_(max_queued) {
  storage_.FailInterruptedJobs("the server stopped before the job finished; submit it again");
  worker_ = std::thread([this] { Run(); });
}

JobQueue::~JobQueue() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  worker_.join();
  for (const auto& [id, work] : queue_) {
    JobRecord j;
    j.id = id;
    j.status = "failed";
    j.error = "the server stopped before the job started; submit it again";
    try {
      TryUpdate(storage_, j, "that it was not started");
    } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw
    }
  }
}

std::int64_t JobQueue::Submit(const std::string& kind, const nlohmann::json& request, Work work) {
  std::lock_guard lock(mu_);
  if (queue_.size() >= max_queued_) {
    throw Unavailable("the job queue is full (" + std::to_string(max_queued_) +
                      " jobs waiting); try again later");
  }
  const std::int64_t id = storage_.CreateJob(kind, request.dump());
  queue_.emplace_back(id, std::move(work));
  cv_.notify_one();
  return id;
}

void JobQueue::Run() {
  while (true) {
    std::pair<std::int64_t, Work> item;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      item = std::move(queue_.front());
      queue_.pop_front();
    }
    // Every storage call below is guarded: the job runs even when its status cannot be
    // written, and the worker goes on to the next job whatever happens to this one.
    try {
      JobRecord job;
      job.id = item.first;
      job.status = "running";
      job.stage = "started";
      TryUpdate(storage_, job, "its start");
      auto progress = [&](double f, const std::string& stage) {
        job.progress = f;
        job.stage = stage;
        TryUpdate(storage_, job, "its progress");
      };
      try {
        const nlohmann::json result = item.second(progress);
        job.status = "done";
        job.progress = 1.0;
        job.stage = "done";
        job.result_json = result.dump();
      } catch (const std::exception& e) {
        job.status = "failed";
        job.error = e.what();
      } catch (...) {
        job.status = "failed";
        job.error = "the job failed with an unknown error";
      }
      const auto error = TryUpdate(storage_, job, "its outcome");
      if (error && job.status == "done") {
        // The result could not be written (too large, disk full): record at least the failure.
        JobRecord failed = job;
        failed.status = "failed";
        failed.stage = "storing the result";
        failed.result_json.clear();
        failed.error = "the result could not be stored: " + *error;
        TryUpdate(storage_, failed, "its failure");
      }
    } catch (...) {
      // Out of memory or the like while handling one job: the worker stays for the next.
      try {
        std::cerr << "kinemetricd: job " << item.first << ": aborted" << std::endl;
      } catch (...) {  // NOLINT(bugprone-empty-catch): nothing is left to report to
      }
    }
  }
}

nlohmann::json JobJson(const JobRecord& job) {
  nlohmann::json j;
  j["id"] = job.id;
  j["kind"] = job.kind;
  j["status"] = job.status;
  j["progress"] = job.progress;
  j["stage"] = job.stage;
  j["created_at"] = job.created_at;
  j["updated_at"] = job.updated_at;
  j["request"] =
      job.request_json.empty() ? nlohmann::json(nullptr) : nlohmann::json::parse(job.request_json);
  if (!job.result_json.empty()) j["result"] = nlohmann::json::parse(job.result_json);
  if (!job.error.empty()) j["error"] = job.error;
  const JobVerdict v =
      JudgeJob(job.kind, job.status, j.value("result", nlohmann::json()), job.error);
  j["verdict"] = v.verdict.empty() ? nlohmann::json(nullptr) : nlohmann::json(v.verdict);
  j["verdict_reasons"] = v.reasons;
  return j;
}

namespace {

// A figure in a sentence: whole numbers from 100 up, else three significant digits.
std::string Num(double v) {
  char buf[64];
  if (std::fabs(v) >= 100.0) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%.3g", v);
  }
  return buf;
}

// The largest value of a nested array of numbers (parameter_uncertainty_um's groups);
// NaN when a value is missing or not finite (null in the JSON).
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

struct Judgement {
  bool failed = false;
  std::vector<std::string> reasons;
  void Warn(const std::string& why) { reasons.push_back(why); }
  void Fail(const std::string& why) {
    failed = true;
    reasons.push_back(why);
  }
};

// bound: the condition number above which the study is ill-conditioned (0: only a number that
// is not finite counts).
void JudgeConditioning(const nlohmann::json& r, double bound, Judgement& out) {
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
    out.Warn("ill-conditioned: condition number " + Num(cond) + " (above " + Num(bound) +
             "): the tests do not tell the parameters apart");
  }
}

void JudgeCalibration(const nlohmann::json& r, Judgement& out) {
  if (r.contains("converged") && r["converged"].is_boolean() && !r["converged"].get<bool>()) {
    const std::string it =
        r.contains("iterations") && r["iterations"].is_number_integer()
            ? " after " + std::to_string(r["iterations"].get<long long>()) + " iterations"
            : "";
    out.Warn("not converged: the solver stopped" + it + " before the parameters settled");
  }
  JudgeConditioning(r, kIllConditionedAbove, out);
  if (r.contains("parameter_uncertainty_um")) {
    double largest = 0.0;
    bool bad = false;
    LargestOf(r["parameter_uncertainty_um"], largest, bad);
    if (bad) {
      out.Fail("under-determined: a parameter uncertainty is not finite");
    } else if (largest > kUndeterminedAboveUm) {
      out.Warn("under-determined: parameter uncertainty up to ±" + Num(largest) + " µm (above ±" +
               Num(kUndeterminedAboveUm) +
               " µm): the tests do not determine the parameters; add tests in other poses");
    }
  }
  // Parameters fixed beyond the method's gauge (none for absolute; the 6 rigid motions of the
  // base for centre-corrected, [PM-600 report] §2.3) are ones these tests cannot identify.
  const auto fixed = r.value("fixed_parameters", nlohmann::json::array());
  const std::size_t gauge = r.value("method", std::string()) == "centre_corrected" ? 6 : 0;
  if (fixed.is_array() && fixed.size() > gauge) {
    out.Warn("under-determined: " + std::to_string(fixed.size()) +
             " parameters cannot be identified from these tests and were fixed (" +
             (gauge == 0 ? std::string("an absolute calibration fixes none")
                         : "a centre-corrected one fixes the " + std::to_string(gauge) +
                               " rigid motions of the base") +
             ")");
  }
}

void JudgeDiscovery(const nlohmann::json& r, Judgement& out) {
  const std::string verdict = r.value("verdict", std::string());
  const std::string stop = r.value("stop_reason", std::string());
  if (verdict == "model misfit") {
    out.Warn("model misfit: the tests show an error no candidate effect describes" +
             (stop.empty() ? std::string() : " (stopped because " + stop + ")"));
  } else if (verdict != "complete") {
    out.Warn("no clear verdict from the study" +
             (verdict.empty() ? std::string() : " ('" + verdict + "')"));
  }
  // The final fit's condition number mixes parameters of different units (kinematic µm, effect
  // coefficients): no bound applies to it, but it must be a number.
  JudgeConditioning(r, 0.0, out);
}

}  // namespace

JobVerdict JudgeJob(const std::string& kind, const std::string& status,
                    const nlohmann::json& result, const std::string& error) {
  if (status == "failed") return {"failed", {error.empty() ? "the job failed" : error}};
  if (status != "done") return {};
  Judgement j;
  if (!result.is_object()) {
    j.Fail("the job stored no result");
  } else if (kind == "hexapod_calibration") {
    JudgeCalibration(result, j);
  } else if (kind == "discovery") {
    JudgeDiscovery(result, j);
  }
  if (j.reasons.empty()) return {"ok", {}};
  return {j.failed ? "failed" : "warning", j.reasons};
}

}  // namespace km::server
