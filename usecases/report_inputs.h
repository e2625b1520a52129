// What a report is made from, as the service and the command line hand it over: where the
// measurement came from, the machine's audit, the machine as left and the certificate
// (usecases/pdf_reports.h builds the reports; usecases/pdf_reports_text.h words them).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace km::usecases {

// Where a measurement came from.
struct ReportSource {
  std::optional<std::int64_t> measurement_id;  // none: a file given to the command line
  std::string kind, machine_id, test_id, direction, filename, measured_at, uploaded_at;
  nlohmann::json metadata = nlohmann::json::object();  // the file's header keys
};

// The machine's accuracy audit as stored: its rules (null: none) and newest verdict (null: none).
struct ReportAudit {
  nlohmann::json config;
  nlohmann::json verdict;
};

// The machine as left: a later test of the same set-up that the user chose (before and after an
// adjustment), with its result object.
struct ReportLater {
  std::int64_t measurement_id = 0;
  std::string measured_at;
  nlohmann::json results;
};

// The certificate a report is (server/reports/certificates.h): its number, the revision printed
// and its approval.
struct ReportCertificate {
  std::string number;  // e.g. "KM-M000042"
  std::int64_t revision = 1;
  std::string approved_by;  // empty: a draft, not approved
  std::string approved_at;  // ISO 8601 UTC
  // The newest earlier approved revision ("revision 1, approved by … at …"); empty: none.
  std::string supersedes;
};

}  // namespace km::usecases
