// The certificates the PDF reports are (docs/http.md "Certificates"): every report has a number
// (a measurement KM-M000042, with a chosen as-left test KM-M000042-L000057, a job KM-J000007, a
// machine's audit KM-A-<machine>) and revisions 1, 2, … — a new revision is made when what the
// report certifies changes (the measurement's result and uncertainty, the instrument as the
// register completes it, the tolerance table and decision, the as-left test; a job's result; an
// audit's rules and newest verdict), never on printing alone. An engineer approves the current
// revision: who and when are stored with the PDF as approved, which every later request for that
// revision answers byte for byte; a change after that makes a new, unapproved revision.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/storage/report_store.h"
#include "usecases/pdf_reports.h"

namespace km::server {

// What a report certifies and how its certificate is named.
struct CertificateSubject {
  std::string subject;  // the storage key: "measurement 42", "measurement 42 as-left 57", …
  std::string number;   // "KM-M000042", "KM-M000042-L000057", "KM-J000007", "KM-A-vmc"
};

CertificateSubject MeasurementCertificate(MeasurementId id, std::optional<MeasurementId> as_left);
CertificateSubject JobCertificate(JobId id);
CertificateSubject AuditCertificate(const std::string& machine_id);

// Who approves: the token presented (its id and name).
struct ReportApprover {
  TokenId token_id;
  std::string name;
};

class Certificates {
 public:
  explicit Certificates(ReportStore& store) : store_(store) {}

  // The current revision of the subject for this content (appended when its SHA-256 differs
  // from the newest revision's); `summary` is kept with a new revision for the listing.
  ReportRevisionRecord Current(const CertificateSubject& s, const nlohmann::json& content,
                               const nlohmann::json& summary);
  // The certificate lines of a revision as printed (number, revision, approval, the newest
  // earlier approved revision it supersedes).
  usecases::ReportCertificate Printed(const CertificateSubject& s,
                                      const ReportRevisionRecord& revision);
  // {"certificate", "subject", "current_revision", "revisions": [{"revision", "created_at",
  // "summary", "approved_by"?, "approved_at"?}]}.
  nlohmann::json Revisions(const CertificateSubject& s, const ReportRevisionRecord& current);
  // The approved PDF of an earlier revision; NotFound when that revision was never approved (only
  // approved revisions are kept as printed) or does not exist.
  std::string ApprovedPdf(const CertificateSubject& s, std::int64_t revision, std::int64_t current);
  // A revision an approver names, checked against the stored revisions before the report is
  // made again: Conflict when it is already approved or not the newest stored.
  void CheckNamedRevision(const CertificateSubject& s, std::int64_t revision);
  // Checks that `expected` (when given) is the current revision and that it is not approved yet
  // (Conflict otherwise, naming the revision and who approved it).
  void CheckApprovable(const CertificateSubject& s, const ReportRevisionRecord& current,
                       std::optional<std::int64_t> expected);
  // Stores the approval with its PDF; Conflict when another approval came first.
  nlohmann::json Approve(const CertificateSubject& s, const ReportRevisionRecord& current,
                         const ReportApprover& by, const std::string& at, const std::string& pdf);
  ReportStore& store() { return store_; }

 private:
  ReportStore& store_;
};

}  // namespace km::server
