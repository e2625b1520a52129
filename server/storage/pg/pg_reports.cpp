// Report revisions and approvals in the PostgreSQL backend: tables report_revisions and
// report_approvals (migration 13), appended only (triggers refuse UPDATE, DELETE and TRUNCATE).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

constexpr const char* kRevisionColumns =
    "r.subject, r.revision, r.created_at, r.content_sha256, r.summary_json, a.approved_by, "
    "a.token_id, a.approved_at";

ReportRevisionRecord ReadRevisionRow(const pg::Result& s, int i) {
  ReportRevisionRecord r;
  r.subject = s.Text(i, 0);
  r.revision = s.Int(i, 1);
  r.created_at = s.Text(i, 2);
  r.content_sha256 = s.Text(i, 3);
  r.summary_json = s.Text(i, 4);
  if (!s.IsNull(i, 5)) {
    r.approval = ReportApprovalRecord{
        r.subject, r.revision, s.Text(i, 5), TokenId(s.Int(i, 6)), s.Text(i, 7), std::string()};
  }
  return r;
}

std::string RevisionQuery(const char* where) {
  return std::string("SELECT ") + kRevisionColumns +
         " FROM report_revisions AS r LEFT JOIN report_approvals AS a ON a.subject = r.subject "
         "AND a.revision = r.revision WHERE " +
         where;
}

}  // namespace

ReportRevisionPut PgStorage::PutReportRevision(const NewReportRevision& n) {
  pg::Params key;
  key.Key(n.subject, "subject");
  auto c = pool_->Acquire();
  pg::Transaction tx(*c);
  // Writers of the same subject (in any instance) take turns until their transaction ends.
  c->Query("SELECT pg_advisory_xact_lock(hashtextextended($1, 13))", key, "lock report");
  std::int64_t newest = 0;
  {
    const pg::Result s = c->Query(RevisionQuery("r.subject = $1 ORDER BY r.revision DESC LIMIT 1"),
                                  key, "read report revision");
    if (s.Rows() > 0) {
      ReportRevisionRecord r = ReadRevisionRow(s, 0);
      if (r.content_sha256 == n.content_sha256) return ReportRevisionPut{std::move(r), false};
      newest = r.revision;
    }
  }
  ReportRevisionRecord r{n.subject,        newest + 1,     NowUtcIso8601(),
                         n.content_sha256, n.summary_json, std::nullopt};
  pg::Params p;
  p.Text(r.subject, "subject").Int(r.revision).Text(r.created_at, "created_at");
  p.Text(r.content_sha256, "content_sha256").Text(r.summary_json, "summary");
  c->Query(
      "INSERT INTO report_revisions (subject, revision, created_at, content_sha256, "
      "summary_json) VALUES ($1, $2, $3, $4, $5)",
      p, "store report revision");
  tx.Commit();
  return ReportRevisionPut{std::move(r), true};
}

std::vector<ReportRevisionRecord> PgStorage::ListReportRevisions(const std::string& subject) {
  auto c = pool_->Acquire();
  pg::Params p;
  p.Text(subject, "subject");
  const pg::Result s =
      c->Query(RevisionQuery("r.subject = $1 ORDER BY r.revision"), p, "list report revisions");
  std::vector<ReportRevisionRecord> out;
  for (int i = 0; i < s.Rows(); ++i) out.push_back(ReadRevisionRow(s, i));
  return out;
}

bool PgStorage::AddReportApproval(const ReportApprovalRecord& a) {
  auto c = pool_->Acquire();
  pg::Params p;
  p.Text(a.subject, "subject").Int(a.revision).Text(a.approved_by, "approved_by").Int(a.token_id);
  p.Text(a.approved_at.empty() ? NowUtcIso8601() : a.approved_at, "approved_at").Bytes(a.pdf);
  const auto r = c->Query(
      "INSERT INTO report_approvals (subject, revision, approved_by, token_id, approved_at, pdf) "
      "VALUES ($1, $2, $3, $4, $5, $6) ON CONFLICT (subject, revision) DO NOTHING",
      p, "store report approval");
  return r.Affected() == 1;
}

std::optional<std::string> PgStorage::ReportApprovalPdf(const std::string& subject,
                                                        std::int64_t revision) {
  auto c = pool_->Acquire();
  pg::Params p;
  p.Text(subject, "subject").Int(revision);
  const pg::Result s =
      c->Query("SELECT pdf FROM report_approvals WHERE subject = $1 AND revision = $2", p,
               "read report approval", true);
  if (s.Rows() == 0) return std::nullopt;
  return s.Bytes(0, 0);
}

}  // namespace km::server
