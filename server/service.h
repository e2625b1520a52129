// The service: one application service a capability, built over one storage and wired here.
// The API's routes (api/) and the tools call the capability they serve:
//   measurements()  uploads of every format, results, lists, recomputed queries
//                   (server/measurements/measurement_service.h)
//   models()        versioned machine definitions (server/models/model_service.h)
//   studies()       calibration and discovery studies as background jobs
//                   (server/jobs/study_service.h)
//   streams()       sensor streams and Modbus acquisition (server/streams/stream_service.h)
//   servo()         servo-load analyses of stored records (server/servo/servo_service.h)
//   access()        tokens and the audit log (server/access/access.h)
//   audits()        accuracy audits and their scheduler (server/audits/audit_scheduler.h)
//   reports()       PDF reports of measurements, jobs and audits (server/reports/report_service.h)
//   tolerances()    the machines' tolerance tables, versioned; the measurements are judged
//                   against them (server/tolerances/tolerance_service.h)
//   instruments()   the instrument register, versioned; an uploaded file naming a registered
//                   serial takes its uncertainties (server/instruments/instrument_service.h)
// The audit scheduler sees only the narrow AuditSource it reads (storage roles, the DBB pair
// analysis and the jobs' verdicts), not this class.
#pragma once

#include <memory>

#include "server/access/access.h"
#include "server/audits/audit_scheduler.h"
#include "server/audits/audit_source.h"
#include "server/instruments/instrument_service.h"
#include "server/jobs/study_service.h"
#include "server/measurements/measurement_service.h"
#include "server/models/model_service.h"
#include "server/reports/report_service.h"
#include "server/servo/servo_service.h"
#include "server/storage/storage.h"
#include "server/streams/stream_service.h"
#include "server/tolerances/tolerance_service.h"

namespace km::server {

struct ServiceOptions {
  std::size_t max_upload_bytes = 32u << 20;
  // Checked in one pass before anything is parsed; an upload beyond them is refused with
  // km::TooLarge (HTTP 413) naming the file and the first line beyond the limit. A format
  // without an entry gets the TextLimits defaults.
  std::map<std::string, ingest::TextLimits> upload_limits = DefaultUploadLimits();
  // Hexapod calibration and discovery requests: at most this many DBB tests (a study uses
  // tens), and at most this many samples in all of them (the running job holds every test).
  std::size_t max_calibration_tests = 500;
  std::size_t max_calibration_samples = 2'000'000;
  // Accuracy audits: the webhook of verdicts of level 2 and 3 (server/audits/audit_scheduler.h).
  AuditOptions audits;
  // Background jobs: workers of this instance, lease, queue bound (server/jobs/jobs.h).
  JobQueueOptions jobs;
};

class Service : public AuditSource {
 public:
  // Starts the job workers; the audit scheduler starts with audits().Start() (the server does).
  Service(std::unique_ptr<Storage> storage, ServiceOptions options);
  ~Service() override;
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  MeasurementService& measurements() { return measurements_; }
  ModelService& models() { return models_; }
  StudyService& studies() { return *studies_; }
  StreamService& streams() { return *streams_; }
  ServoService& servo() { return servo_; }
  AccessService& access() { return access_; }
  AuditScheduler& audits() { return *audits_; }
  ReportService& reports() { return reports_; }
  ToleranceService& tolerances() { return tolerances_; }
  InstrumentService& instruments() { return instruments_; }

  // The storage itself, for tests and tools (the routes use the services).
  Storage& storage() { return *storage_; }

  // AuditSource: the storage roles the audits read, the DBB pair analysis, the jobs' verdicts.
  MeasurementStore& measurement_store() override { return *storage_; }
  JobStore& job_store() override { return *storage_; }
  AuditStore& audit_store() override { return *storage_; }
  ToleranceStore& tolerance_store() override { return *storage_; }
  AccessStore& access_store() override { return *storage_; }
  nlohmann::json DbbPairJson(MeasurementId id) override { return measurements_.DbbPairJson(id); }
  JobVerdict JobVerdictOf(const JobRecord& job, const nlohmann::json& result) override {
    return studies_->Verdict(job, result);
  }

 private:
  std::unique_ptr<Storage> storage_;
  ToleranceService tolerances_;
  InstrumentService instruments_;
  MeasurementService measurements_;
  ModelService models_;
  AccessService access_;
  std::unique_ptr<StreamService> streams_;
  ServoService servo_;
  std::unique_ptr<StudyService> studies_;  // stopped before the streams
  ReportService reports_;
  std::unique_ptr<AuditScheduler> audits_;  // last: stopped first
};

}  // namespace km::server
