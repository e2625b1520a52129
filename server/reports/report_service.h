// PDF reports of what the service stores (usecases/pdf_reports.h gives their content,
// render/pdf_report.h draws them): a measurement (a DBB test with its partner, its machine's
// audit rules and newest verdict, as found / as left when a later test of the same set-up is
// stored; any other kind with its figures), a calibration or discovery job, a machine's
// accuracy audit. Each answer is the bytes of one PDF document, of at most
// render::kMaxReportPages pages (long tables summarised, saying so). Reports are made through a
// RenderGate (server/reports/render_gate.h): a few at a time on its own threads, more refused
// with km::Unavailable (HTTP 503 with Retry-After); Stop gives the server's stop a deadline.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

#include "server/audits/audit_source.h"
#include "server/jobs/study_service.h"
#include "server/measurements/measurement_service.h"
#include "server/reports/certificates.h"
#include "server/reports/render_gate.h"

namespace km::server {

// Which report of a measurement: the as-left test the user chose (another test of the same
// set-up measured later), and an earlier revision (only approved ones are kept as printed).
struct ReportRequest {
  std::optional<MeasurementId> as_left;
  std::optional<std::int64_t> revision;
};

class ReportService {
 public:
  ReportService(AuditSource& records, MeasurementService& measurements, StudyService& studies,
                ReportStore& certificates, RenderGateOptions gate = {})
      : records_(records),
        measurements_(measurements),
        studies_(studies),
        certificates_(certificates),
        gate_(gate) {}

  // GET /api/v1/measurements/{id}/report.pdf; NotFound for an unknown measurement, InvalidInput
  // naming `as_left` for a test that is not a later test of the same set-up.
  std::string MeasurementPdf(MeasurementId id, const ReportRequest& request = {});
  // GET /api/v1/jobs/{id}/report.pdf; NotFound for an unknown job.
  std::string JobPdf(JobId id, std::optional<std::int64_t> revision = std::nullopt);
  // GET /api/v1/machines/{machine_id}/audit/report.pdf; NotFound for a machine with neither
  // an audit nor a verdict.
  std::string AuditPdf(const std::string& machine_id,
                       std::optional<std::int64_t> revision = std::nullopt);

  // GET …/report/revisions: the certificate's revisions (Certificates::Revisions).
  nlohmann::json MeasurementRevisions(MeasurementId id, std::optional<MeasurementId> as_left);
  nlohmann::json JobRevisions(JobId id);
  nlohmann::json AuditRevisions(const std::string& machine_id);
  // POST …/report/approve: approves the current revision (`revision`, when given, must be it;
  // Conflict otherwise or when it is already approved) and freezes its PDF.
  nlohmann::json ApproveMeasurement(MeasurementId id, std::optional<MeasurementId> as_left,
                                    std::optional<std::int64_t> revision, const ReportApprover& by);
  nlohmann::json ApproveJob(JobId id, std::optional<std::int64_t> revision,
                            const ReportApprover& by);
  nlohmann::json ApproveAudit(const std::string& machine_id, std::optional<std::int64_t> revision,
                              const ReportApprover& by);

  // The server is stopping: reports asked for or waiting from now on are refused (503), the
  // ones being made give up at `cancel_at` (before the server's shutdown deadline).
  void Stop(std::chrono::steady_clock::time_point cancel_at) { gate_.Stop(cancel_at); }

 private:
  using Cancelled = std::function<bool()>;
  // A report ready to be certified: what it certifies, and how it is drawn.
  struct Prepared {
    CertificateSubject subject;
    nlohmann::json content, summary;
    std::function<render::Report(const Cancelled&)> build;
  };
  Prepared PrepareMeasurement(MeasurementId id, std::optional<MeasurementId> as_left);
  Prepared PrepareJob(JobId id);
  Prepared PrepareAudit(const std::string& machine_id);
  std::string Pdf(const std::function<Prepared()>& prepare, std::optional<std::int64_t> revision);
  nlohmann::json Approve(const CertificateSubject& subject,
                         const std::function<Prepared()>& prepare,
                         std::optional<std::int64_t> revision, const ReportApprover& by);
  nlohmann::json Revisions(const Prepared& p);
  AuditSource& records_;
  MeasurementService& measurements_;
  StudyService& studies_;
  Certificates certificates_;
  RenderGate gate_;  // last: its threads stop before the services they use go
};

}  // namespace km::server
