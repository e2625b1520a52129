// The revisions of the reports a lab signs (server/reports/certificates.h), as the storage keeps
// them: each report subject ("measurement 42", "job 7", …) has revisions 1, 2, … appended when
// what the report certifies changes; an approval freezes one revision with the PDF as approved.
// Neither a revision nor an approval is ever changed or removed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "server/base/ids.h"

namespace km::server {

struct NewReportRevision {
  std::string subject;         // e.g. "measurement 42", "measurement 42 as-left 57", "job 7"
  std::string content_sha256;  // of what the revision certifies
  std::string summary_json;    // what it was made from (versions and ids), for the listing
};

struct ReportApprovalRecord {
  std::string subject;
  std::int64_t revision = 0;
  std::string approved_by;  // the approving token's name
  TokenId token_id;
  std::string approved_at;  // ISO 8601 UTC
  std::string pdf;          // the approved document; empty when listed
};

struct ReportRevisionRecord {
  std::string subject;
  std::int64_t revision = 0;
  std::string created_at;
  std::string content_sha256;
  std::string summary_json;
  std::optional<ReportApprovalRecord> approval;  // without its pdf
};

struct ReportRevisionPut {
  ReportRevisionRecord record;
  bool created = false;
};

class ReportStore {
 public:
  virtual ~ReportStore() = default;

  // Appends the subject's next revision atomically unless its newest revision has the same
  // content_sha256 (then that one is answered, created = false, nothing written).
  virtual ReportRevisionPut PutReportRevision(const NewReportRevision& revision) = 0;
  // Every revision of the subject, oldest first, each with its approval (pdf left empty).
  virtual std::vector<ReportRevisionRecord> ListReportRevisions(const std::string& subject) = 0;
  // Records the approval of an existing revision; false (nothing written) when that revision is
  // already approved.
  virtual bool AddReportApproval(const ReportApprovalRecord& approval) = 0;
  // The approved PDF of a revision; nullopt when the revision is not approved.
  virtual std::optional<std::string> ReportApprovalPdf(const std::string& subject,
                                                       std::int64_t revision) = 0;
};

}  // namespace km::server
