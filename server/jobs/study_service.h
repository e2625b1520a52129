// Studies of stored DBB tests that run as background jobs: hexapod calibrations
// (calibration_jobs.cpp) and model-gap discoveries (discovery_jobs.cpp). A request is checked
// completely before it is queued, from the stored records alone; the queued job keeps the ids
// and reads each test once when it runs, on whichever instance takes it (server/jobs/jobs.h).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/core/progress.h"
#include "server/jobs/job_kinds.h"
#include "server/jobs/jobs.h"
#include "server/jobs/study_requests.h"
#include "server/measurements/measurement_service.h"
#include "server/models/model_service.h"
#include "server/storage/storage.h"

namespace km::server {

struct StudyOptions {
  // At most this many DBB tests a study (a study uses tens), and at most this many samples in
  // all of them (the running job holds every test in memory).
  std::size_t max_calibration_tests = 500;
  std::size_t max_calibration_samples = 2'000'000;
  // Background jobs: workers of this instance, lease, queue bound (server/jobs/jobs.h).
  JobQueueOptions jobs;
};

// Who asks to cancel a job (StudyService::CancelJob): the caller's token and whether it is an
// admin.
struct JobCanceller {
  std::optional<TokenId> token_id;
  std::string token_name;
  bool admin = false;
};

struct CalibrationPlan;
struct DiscoveryPlan;

// The kinds of job the studies register (StudyService's constructor), each with its runner and
// its judge.
inline constexpr const char* kCalibrationJob = "hexapod_calibration";
inline constexpr const char* kDiscoveryJob = "discovery";

// Above this condition number (of the Jacobian over the free parameters) the tests do not tell
// the parameters apart: small changes of the readings move them a lot.
inline constexpr double kIllConditionedAbove = 1e4;
// Above this standard uncertainty of an identified parameter (µm) the tests do not determine it:
// the errors a calibration corrects are tens of µm.
inline constexpr double kUndeterminedAboveUm = 25.0;

// The judges of the studies' results (docs/formats.md §5), registered beside their runners: a
// calibration not converged, ill-conditioned (above kIllConditionedAbove), under-determined
// (a parameter's σ above kUndeterminedAboveUm, or fixed beyond the method's gauge); a discovery
// ending in model misfit or without a clear verdict, or whose condition number is not finite.
void JudgeCalibrationResult(const nlohmann::json& result, JobFindings& out);
void JudgeDiscoveryResult(const nlohmann::json& result, JobFindings& out);

class StudyService {
 public:
  // Starts the job queue's workers; the destructor stops them.
  StudyService(MeasurementStore& measurements_store, JobStore& jobs_store,
               MeasurementService& measurements, ModelService& models, StudyOptions options);
  StudyService(const StudyService&) = delete;
  StudyService& operator=(const StudyService&) = delete;

  // Hexapod calibration study (server/jobs/study_requests.h), checked now from the stored
  // records, without reading any file (InvalidInput / NotFound): at most max_calibration_tests
  // ids, each a DBB test with a tool length (and its fixed ball for the absolute method), of one
  // machine, at most max_calibration_samples samples in all; a stored model must be a hexapod;
  // the reduction study is refused together with effects (named, or the stored model's own).
  // Returns the job id. The job's result is the `hexapod calibrate` object plus the calibrated
  // machine; its request records the stored model's version used. owner_token_id: the token
  // submitting the job, who may cancel it (CancelJob).
  JobId SubmitCalibration(const CalibrationRequest& request,
                          std::optional<TokenId> owner_token_id = std::nullopt);
  // Model-gap discovery study (usecases/discovery_report.h), checked like a calibration. Without
  // a model: the serial study of the DBB tests' machine; with one: the stored model (a
  // hexapod's tests need the tool length). The job's result is the `kinemetric discover`
  // object, plus "updated_machine" when the study produced one.
  JobId SubmitDiscovery(const DiscoveryRequest& request,
                        std::optional<TokenId> owner_token_id = std::nullopt);

  nlohmann::json Job(JobId id);
  // The verdict on a stored job by its kind's judge (the audits read calibrations with it).
  JobVerdict Verdict(const JobRecord& job, const nlohmann::json& result) const {
    return kinds_.Verdict(job, result);
  }
  // Cancels a queued or running job for its owner (the token that submitted it) or an admin;
  // answers the job, status "cancelled" (its error says by whom). A running job stops at its
  // next progress report. NotFound: no such job; Forbidden: `by` neither owns it nor is an
  // admin; Conflict: the job is done, failed or cancelled already.
  nlohmann::json CancelJob(JobId id, const JobCanceller& by);
  nlohmann::json Jobs(std::int64_t limit);
  // The jobs of one machine, newest first, as Jobs: those whose request names the machine
  // (machine_id) or whose DBB tests are of it; among the newest `scan` jobs.
  nlohmann::json JobsOfMachine(const std::string& machine_id, std::int64_t limit,
                               std::int64_t scan = 5000);
  // Stores the machine a finished job produced (a calibration's calibrated machine, a
  // discovery's updated machine) as the next version of its model, source "calibration job N"
  // or "discovery job N". NotFound: no such job; Conflict: the job is not done, or produced no
  // machine.
  MachineModelStored SaveJobMachine(JobId job_id, const std::string& note);

  // Stops the workers (a running job goes back to the queue).
  void Stop() { queue_.Stop(); }

 private:
  // The measurement ids of a study request, checked from the stored records alone (no file is
  // read): at most max_calibration_tests, each listed once, each a DBB test (with a tool length
  // and, when asked, a fixed ball), all of one machine, at most max_calibration_samples samples
  // in all (calibration_jobs.cpp).
  std::vector<std::int64_t> CheckedDbbIds(const std::vector<std::int64_t>& ids,
                                          const std::string& study, bool need_tool_length,
                                          bool need_fixed_ball);
  // Study requests checked into what a job runs, and the jobs' runners (from the stored plan).
  std::shared_ptr<CalibrationPlan> CheckCalibration(const CalibrationRequest& request,
                                                    std::int64_t& stored_version);
  std::shared_ptr<DiscoveryPlan> CheckDiscovery(const DiscoveryRequest& request,
                                                std::int64_t& version);
  // The plan a worker runs from a stored plan (the checked request): the machine resolved, the
  // request's fields taken; the checks of the stored records are not repeated.
  std::shared_ptr<CalibrationPlan> ResolveCalibration(const CalibrationRequest& request,
                                                      std::int64_t& stored_version);
  std::shared_ptr<DiscoveryPlan> ResolveDiscovery(const DiscoveryRequest& request,
                                                  std::int64_t& version);
  JobOutput RunCalibrationJob(const nlohmann::json& plan, const ProgressFn& p);
  JobOutput RunDiscoveryJob(const nlohmann::json& plan, const ProgressFn& p);
  // The job as GET /api/v1/jobs/{id} answers it: JobKinds::Json with "machine_id", the machine the
  // job is of — the one its request names, else that of its first DBB test (a serial discovery);
  // null when neither is known. `machine_of` keeps the tests' machines looked up (a list asks
  // for many jobs of the same tests).
  nlohmann::json AnsweredJob(const JobRecord& job, std::map<std::int64_t, std::string>& machine_of);
  // The machine of the first DBB test a job's request lists; "" when unknown.
  std::string TestsMachine(const nlohmann::json& request,
                           std::map<std::int64_t, std::string>& machine_of);

  MeasurementStore& measurement_store_;
  JobStore& job_store_;
  MeasurementService& measurements_;
  ModelService& models_;
  StudyOptions options_;
  JobKinds kinds_;
  JobQueue queue_;  // last: its workers stop before the rest goes
};

}  // namespace km::server
