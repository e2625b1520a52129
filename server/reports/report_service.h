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
#include "server/reports/render_gate.h"

namespace km::server {

class ReportService {
 public:
  ReportService(AuditSource& records, MeasurementService& measurements, StudyService& studies,
                RenderGateOptions gate = {})
      : records_(records), measurements_(measurements), studies_(studies), gate_(gate) {}

  // GET /api/v1/measurements/{id}/report.pdf; NotFound for an unknown measurement.
  std::string MeasurementPdf(std::int64_t id);
  // GET /api/v1/jobs/{id}/report.pdf; NotFound for an unknown job.
  std::string JobPdf(std::int64_t id);
  // GET /api/v1/machines/{machine_id}/audit/report.pdf; NotFound for a machine with neither
  // an audit nor a verdict.
  std::string AuditPdf(const std::string& machine_id);

  // The server is stopping: reports asked for or waiting from now on are refused (503), the
  // ones being made give up at `cancel_at` (before the server's shutdown deadline).
  void Stop(std::chrono::steady_clock::time_point cancel_at) { gate_.Stop(cancel_at); }

 private:
  using Cancelled = std::function<bool()>;
  std::string DbbPdf(const MeasurementRecord& rec, const Cancelled& cancelled);
  std::string ResultsPdf(const MeasurementRecord& rec, const Cancelled& cancelled);
  AuditSource& records_;
  MeasurementService& measurements_;
  StudyService& studies_;
  RenderGate gate_;  // last: its threads stop before the services they use go
};

}  // namespace km::server
