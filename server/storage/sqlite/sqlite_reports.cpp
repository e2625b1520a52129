// Report revisions and approvals in the SQLite backend: tables report_revisions and
// report_approvals (migration 13), appended only (triggers refuse UPDATE and DELETE).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

constexpr const char* kRevisionColumns =
    "r.subject, r.revision, r.created_at, r.content_sha256, r.summary_json, a.approved_by, "
    "a.token_id, a.approved_at";

ReportRevisionRecord ReadRevisionRow(const sqlite::Statement& s) {
  ReportRevisionRecord r;
  r.subject = s.Text(0);
  r.revision = s.Int(1);
  r.created_at = s.Text(2);
  r.content_sha256 = s.Text(3);
  r.summary_json = s.Text(4);
  if (!s.IsNull(5))
    r.approval = ReportApprovalRecord{r.subject,         r.revision, s.Text(5),
                                      TokenId(s.Int(6)), s.Text(7),  std::string()};
  return r;
}

std::string RevisionQuery(const char* where) {
  return std::string("SELECT ") + kRevisionColumns +
         " FROM report_revisions AS r LEFT JOIN report_approvals AS a ON a.subject = r.subject "
         "AND a.revision = r.revision WHERE " +
         where;
}

}  // namespace

ReportRevisionPut SqliteStorage::PutReportRevision(const NewReportRevision& n) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);  // BEGIN IMMEDIATE: no other writer between reading and appending
  std::int64_t newest = 0;
  {
    auto s = Prepared(RevisionQuery("r.subject = ? ORDER BY r.revision DESC LIMIT 1"));
    s->Bind(1, n.subject);
    if (s->Step()) {
      ReportRevisionRecord r = ReadRevisionRow(*s);
      if (r.content_sha256 == n.content_sha256) return ReportRevisionPut{std::move(r), false};
      newest = r.revision;
    }
  }
  ReportRevisionRecord r{n.subject,        newest + 1,     NowUtcIso8601(),
                         n.content_sha256, n.summary_json, std::nullopt};
  auto s = Prepared(
      "INSERT INTO report_revisions (subject, revision, created_at, content_sha256, "
      "summary_json) VALUES (?, ?, ?, ?, ?)");
  s->Bind(1, r.subject).Bind(2, r.revision).Bind(3, r.created_at);
  s->Bind(4, r.content_sha256).Bind(5, r.summary_json);
  s->Step();
  tx.Commit();
  return ReportRevisionPut{std::move(r), true};
}

std::vector<ReportRevisionRecord> SqliteStorage::ListReportRevisions(const std::string& subject) {
  std::lock_guard lock(mu_);
  auto s = Prepared(RevisionQuery("r.subject = ? ORDER BY r.revision"));
  s->Bind(1, subject);
  std::vector<ReportRevisionRecord> out;
  while (s->Step()) out.push_back(ReadRevisionRow(*s));
  return out;
}

bool SqliteStorage::AddReportApproval(const ReportApprovalRecord& a) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);
  {
    auto s = Prepared("SELECT 1 FROM report_approvals WHERE subject = ? AND revision = ?");
    s->Bind(1, a.subject).Bind(2, a.revision);
    if (s->Step()) return false;
  }
  auto s = Prepared(
      "INSERT INTO report_approvals (subject, revision, approved_by, token_id, approved_at, pdf) "
      "VALUES (?, ?, ?, ?, ?, ?)");
  s->Bind(1, a.subject).Bind(2, a.revision).Bind(3, a.approved_by).Bind(4, a.token_id);
  s->Bind(5, a.approved_at.empty() ? NowUtcIso8601() : a.approved_at).BindBlob(6, a.pdf);
  s->Step();
  tx.Commit();
  return true;
}

std::optional<std::string> SqliteStorage::ReportApprovalPdf(const std::string& subject,
                                                            std::int64_t revision) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT pdf FROM report_approvals WHERE subject = ? AND revision = ?");
  s->Bind(1, subject).Bind(2, revision);
  if (!s->Step()) return std::nullopt;
  return s->Blob(0);
}

}  // namespace km::server
