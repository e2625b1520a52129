// PDF reports of what the service stores (usecases/pdf_reports.h gives their content,
// render/pdf_report.h draws them): a measurement (a DBB test with its partner, its machine's
// audit rules and newest verdict, as found / as left when a later test of the same set-up is
// stored; any other kind with its figures), a calibration or discovery job, a machine's
// accuracy audit. Each answer is the bytes of one PDF document.
#pragma once

#include <cstdint>
#include <string>

#include "server/audits/audit_source.h"
#include "server/jobs/study_service.h"
#include "server/measurements/measurement_service.h"

namespace km::server {

class ReportService {
 public:
  ReportService(AuditSource& records, MeasurementService& measurements, StudyService& studies)
      : records_(records), measurements_(measurements), studies_(studies) {}

  // GET /api/v1/measurements/{id}/report.pdf; NotFound for an unknown measurement.
  std::string MeasurementPdf(std::int64_t id);
  // GET /api/v1/jobs/{id}/report.pdf; NotFound for an unknown job.
  std::string JobPdf(std::int64_t id);
  // GET /api/v1/machines/{machine_id}/audit/report.pdf; NotFound for a machine with neither
  // an audit nor a verdict.
  std::string AuditPdf(const std::string& machine_id);

 private:
  std::string DbbPdf(const MeasurementRecord& rec);
  AuditSource& records_;
  MeasurementService& measurements_;
  StudyService& studies_;
};

}  // namespace km::server
