// Background jobs in the SQLite backend (migrations 2, 8, 9 and 14): the job records, and the queue
// every worker takes jobs from under a lease (server/jobs/jobs.h). A claim is one write
// transaction, so two connections never take the same job.
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

using sqlite::Statement;

constexpr const char* kJobColumns =
    "id, kind, status, progress, stage, request_json, result_json, error, created_at, updated_at, "
    "plan_json, lease_owner, lease_until_ms, attempts, owner_token_id, machine_document";

JobRecord ReadJob(const Statement& s) {
  JobRecord j;
  j.id = JobId(s.Int(0));
  j.kind = s.Text(1);
  j.status = StoredJobStatus(s.Text(2));
  j.progress = s.Real(3);
  j.stage = s.Text(4);
  j.request_json = s.Text(5);
  j.result_json = s.Text(6);
  j.error = s.Text(7);
  j.created_at = s.Text(8);
  j.updated_at = s.Text(9);
  j.plan_json = s.Text(10);
  j.lease_owner = s.Text(11);
  j.lease_until_ms = s.Int(12);
  j.attempts = s.Int(13);
  j.owner_token_id = IdOrNone<TokenId>(s.Int(14));
  j.machine_document = s.Text(15);
  return j;
}

}  // namespace

JobId SqliteStorage::CreateJob(const std::string& kind, const std::string& request_json) {
  return QueueJob(NewJob{kind, request_json, request_json, std::nullopt});
}

JobId SqliteStorage::QueueJob(const NewJob& job) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO jobs (kind, status, request_json, plan_json, created_at, updated_at, "
      "owner_token_id) VALUES (?, 'queued', ?, ?, ?, ?, ?)");
  const std::string now = NowUtcIso8601();
  s->Bind(1, job.kind).Bind(2, job.request_json).Bind(3, job.plan_json).Bind(4, now).Bind(5, now);
  s->Bind(6, ValueOrZero(job.owner_token_id));
  s->Step();
  return JobId(sqlite3_last_insert_rowid(db_));
}

void SqliteStorage::UpdateJob(const JobRecord& job) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET status = ?, progress = ?, stage = ?, result_json = ?, error = ?, "
      "updated_at = ? WHERE id = ?");
  s->Bind(1, std::string(ToString(job.status)))
      .BindReal(2, job.progress)
      .Bind(3, job.stage)
      .Bind(4, job.result_json);
  s->Bind(5, job.error).Bind(6, NowUtcIso8601()).Bind(7, job.id);
  s->Step();
}

std::optional<JobRecord> SqliteStorage::GetJob(JobId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?"));
  s->Bind(1, id);
  if (!s->Step()) return std::nullopt;
  return ReadJob(*s);
}

std::vector<JobRecord> SqliteStorage::ListJobs(std::int64_t limit) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ?"));
  s->Bind(1, limit);
  std::vector<JobRecord> out;
  while (s->Step()) out.push_back(ReadJob(*s));
  return out;
}

int SqliteStorage::FailInterruptedJobs(const std::string& reason) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET status = 'failed', error = ?, lease_owner = '', lease_until_ms = 0, "
      "updated_at = ? WHERE status IN ('queued', 'running')");
  s->Bind(1, reason).Bind(2, NowUtcIso8601());
  s->Step();
  return sqlite3_changes(db_);
}

std::map<std::string, std::int64_t> SqliteStorage::CountJobsByStatus() {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT status, COUNT(*) FROM jobs GROUP BY status");
  std::map<std::string, std::int64_t> out;
  while (s->Step()) out[s->Text(0)] = s->Int(1);
  return out;
}

std::int64_t SqliteStorage::CountJobsWithStatus(JobStatus status) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT COUNT(*) FROM jobs WHERE status = ?");
  s->Bind(1, std::string(ToString(status)));
  s->Step();
  return s->Int(0);
}

std::optional<JobRecord> SqliteStorage::ClaimJob(const std::string& owner, std::int64_t now_ms,
                                                 std::int64_t lease_ms, int max_attempts,
                                                 const std::string& abandoned_error) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);
  const std::string now = NowUtcIso8601();
  {
    auto s = Prepared(
        "UPDATE jobs SET status = 'failed', error = ?, lease_owner = '', lease_until_ms = 0, "
        "updated_at = ? WHERE status = 'running' AND lease_until_ms < ? AND attempts >= ?");
    s->Bind(1, abandoned_error).Bind(2, now).Bind(3, now_ms).Bind(4, std::int64_t{max_attempts});
    s->Step();
  }
  std::optional<JobRecord> job;
  {
    auto s = Prepared(std::string("SELECT ") + kJobColumns +
                      " FROM jobs WHERE status = 'queued' OR (status = 'running' AND "
                      "lease_until_ms < ?) ORDER BY id LIMIT 1");
    s->Bind(1, now_ms);
    if (s->Step()) job = ReadJob(*s);
  }
  if (job) {
    job->status = JobStatus::kRunning;
    job->progress = 0.0;
    job->stage = "started";
    job->lease_owner = owner;
    job->lease_until_ms = now_ms + lease_ms;
    job->attempts += 1;
    auto s = Prepared(
        "UPDATE jobs SET status = 'running', progress = 0, stage = 'started', lease_owner = ?, "
        "lease_until_ms = ?, attempts = ?, updated_at = ? WHERE id = ?");
    s->Bind(1, owner).Bind(2, job->lease_until_ms).Bind(3, job->attempts).Bind(4, now);
    s->Bind(5, job->id);
    s->Step();
  }
  tx.Commit();
  return job;
}

bool SqliteStorage::RenewJob(JobId id, const std::string& owner, double progress,
                             const std::string& stage, std::int64_t lease_until_ms) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET progress = ?, stage = ?, lease_until_ms = ?, updated_at = ? "
      "WHERE id = ? AND status = 'running' AND lease_owner = ?");
  s->BindReal(1, progress).Bind(2, stage).Bind(3, lease_until_ms).Bind(4, NowUtcIso8601());
  s->Bind(5, id).Bind(6, owner);
  s->Step();
  return sqlite3_changes(db_) == 1;
}

bool SqliteStorage::FinishJob(const JobRecord& job, const std::string& owner) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET status = ?, progress = ?, stage = ?, result_json = ?, error = ?, "
      "lease_until_ms = 0, updated_at = ?, machine_document = ? "
      "WHERE id = ? AND status = 'running' AND lease_owner = ?");
  s->Bind(1, std::string(ToString(job.status)))
      .BindReal(2, job.progress)
      .Bind(3, job.stage)
      .Bind(4, job.result_json);
  s->Bind(5, job.error).Bind(6, NowUtcIso8601()).Bind(7, job.machine_document);
  s->Bind(8, job.id).Bind(9, owner);
  s->Step();
  return sqlite3_changes(db_) == 1;
}

int SqliteStorage::ReleaseJobs(const std::string& owner) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET status = 'queued', stage = 'waiting for an instance', lease_owner = '', "
      "lease_until_ms = 0, updated_at = ? WHERE status = 'running' AND lease_owner = ?");
  s->Bind(1, NowUtcIso8601()).Bind(2, owner);
  s->Step();
  return sqlite3_changes(db_);
}

bool SqliteStorage::CancelJob(JobId id, const std::string& reason) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE jobs SET status = 'cancelled', stage = 'cancelled', error = ?, lease_until_ms = 0, "
      "updated_at = ? WHERE id = ? AND status IN ('queued', 'running')");
  s->Bind(1, reason).Bind(2, NowUtcIso8601()).Bind(3, id);
  s->Step();
  return sqlite3_changes(db_) == 1;
}

}  // namespace km::server
