// Background jobs in the PostgreSQL backend (migrations 2, 8, 9 and
// 14): the job records, and the queue
// every worker of every instance takes jobs from under a lease (server/jobs/jobs.h). A claim locks
// the row it takes and skips rows other claimers hold, so two never take the same job.
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;

constexpr const char* kJobColumns =
    "id, kind, status, progress, stage, request_json, result_json, error, created_at, updated_at, "
    "plan_json, lease_owner, lease_until_ms, attempts, owner_token_id, machine_document";

JobRecord ReadJob(const Result& s, int row) {
  JobRecord j;
  j.id = JobId(s.Int(row, 0));
  j.kind = s.Text(row, 1);
  j.status = StoredJobStatus(s.Text(row, 2));
  j.progress = s.Real(row, 3);
  j.stage = s.Text(row, 4);
  j.request_json = s.Text(row, 5);
  j.result_json = s.Text(row, 6);
  j.error = s.Text(row, 7);
  j.created_at = s.Text(row, 8);
  j.updated_at = s.Text(row, 9);
  j.plan_json = s.Text(row, 10);
  j.lease_owner = s.Text(row, 11);
  j.lease_until_ms = s.Int(row, 12);
  j.attempts = s.Int(row, 13);
  j.owner_token_id = IdOrNone<TokenId>(s.Int(row, 14));
  j.machine_document = s.Text(row, 15);
  return j;
}

}  // namespace

JobId PgStorage::CreateJob(const std::string& kind, const std::string& request_json) {
  return QueueJob(NewJob{kind, request_json, request_json, std::nullopt});
}

void PgStorage::UpdateJob(const JobRecord& job) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(std::string(ToString(job.status)), "status").Real(job.progress).Text(job.stage, "stage");
  p.Text(job.result_json, "result").Text(job.error, "error").Text(NowUtcIso8601(), "updated_at");
  p.Int(job.id);
  c->Query(
      "UPDATE jobs SET status = $1, progress = $2, stage = $3, result_json = $4, error = $5, "
      "updated_at = $6 WHERE id = $7",
      p, "update job");
}

std::optional<JobRecord> PgStorage::GetJob(JobId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r =
      c->Query(std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = $1", p, "read job");
  if (r.Rows() == 0) return std::nullopt;
  return ReadJob(r, 0);
}

std::vector<JobRecord> PgStorage::ListJobs(std::int64_t limit) {
  auto c = pool_->Acquire();
  Params p;
  if (limit < 0) {
    p.Null();
  } else {
    p.Int(limit);
  }
  const Result r =
      c->Query(std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT $1", p,
               "list jobs");
  std::vector<JobRecord> out;
  for (int i = 0; i < r.Rows(); ++i) out.push_back(ReadJob(r, i));
  return out;
}

int PgStorage::FailInterruptedJobs(const std::string& reason) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(reason, "reason").Text(NowUtcIso8601(), "updated_at");
  return static_cast<int>(
      c->Query("UPDATE jobs SET status = 'failed', error = $1, lease_owner = '', "
               "lease_until_ms = 0, updated_at = $2 "
               "WHERE status IN ('queued', 'running')",
               p, "fail interrupted jobs")
          .Affected());
}

std::map<std::string, std::int64_t> PgStorage::CountJobsByStatus() {
  auto c = pool_->Acquire();
  const Result r = c->Query("SELECT status, COUNT(*) FROM jobs GROUP BY status", "count jobs");
  std::map<std::string, std::int64_t> out;
  for (int i = 0; i < r.Rows(); ++i) out[r.Text(i, 0)] = r.Int(i, 1);
  return out;
}

std::int64_t PgStorage::CountJobsWithStatus(JobStatus status) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(std::string(ToString(status)), "status");
  return c->Query("SELECT COUNT(*) FROM jobs WHERE status = $1", p, "count jobs").Int(0, 0);
}

JobId PgStorage::QueueJob(const NewJob& job) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(job.kind, "kind").Text(job.request_json, "request").Text(job.plan_json, "plan");
  p.Text(NowUtcIso8601(), "created_at").Int(ValueOrZero(job.owner_token_id));
  return JobId(
      c->Query("INSERT INTO jobs (kind, status, request_json, plan_json, created_at, updated_at, "
               "owner_token_id) VALUES ($1, 'queued', $2, $3, $4, $4, $5) RETURNING id",
               p, "queue job")
          .Int(0, 0));
}

std::optional<JobRecord> PgStorage::ClaimJob(const std::string& owner, std::int64_t now_ms,
                                             std::int64_t lease_ms, int max_attempts,
                                             const std::string& abandoned_error) {
  auto c = pool_->Acquire();
  const std::string now = NowUtcIso8601();
  pg::Transaction tx(*c);
  Params fail;
  fail.Text(abandoned_error, "error").Text(now, "updated_at").Int(now_ms).Int(max_attempts);
  c->Query(
      "UPDATE jobs SET status = 'failed', error = $1, lease_owner = '', lease_until_ms = 0, "
      "updated_at = $2 WHERE status = 'running' AND lease_until_ms < $3 AND attempts >= $4",
      fail, "fail abandoned jobs");
  // The oldest job to run that no other claimer holds at this moment (their rows are skipped,
  // not waited for): two claimers never take the same job.
  Params find;
  find.Int(now_ms).Int(max_attempts);
  const Result r = c->Query(std::string("SELECT ") + kJobColumns +
                                " FROM jobs WHERE status = 'queued' OR (status = 'running' AND "
                                "lease_until_ms < $1 AND attempts < $2) ORDER BY id LIMIT 1 "
                                "FOR UPDATE SKIP LOCKED",
                            find, "claim job");
  std::optional<JobRecord> job;
  if (r.Rows() > 0) {
    job = ReadJob(r, 0);
    job->status = JobStatus::kRunning;
    job->progress = 0.0;
    job->stage = "started";
    job->lease_owner = owner;
    job->lease_until_ms = now_ms + lease_ms;
    job->attempts += 1;
    Params p;
    p.Text(owner, "owner").Int(job->lease_until_ms).Int(job->attempts).Text(now, "updated_at");
    p.Int(job->id);
    c->Query(
        "UPDATE jobs SET status = 'running', progress = 0, stage = 'started', lease_owner = $1, "
        "lease_until_ms = $2, attempts = $3, updated_at = $4 WHERE id = $5",
        p, "claim job");
  }
  tx.Commit();
  return job;
}

bool PgStorage::RenewJob(JobId id, const std::string& owner, double progress,
                         const std::string& stage, std::int64_t lease_until_ms) {
  auto c = pool_->Acquire();
  Params p;
  p.Real(progress).Text(stage, "stage").Int(lease_until_ms).Text(NowUtcIso8601(), "updated_at");
  p.Int(id).Text(owner, "owner");
  return c->Query(
              "UPDATE jobs SET progress = $1, stage = $2, lease_until_ms = $3, updated_at = $4 "
              "WHERE id = $5 AND status = 'running' AND lease_owner = $6",
              p, "renew job")
             .Affected() == 1;
}

bool PgStorage::FinishJob(const JobRecord& job, const std::string& owner) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(std::string(ToString(job.status)), "status").Real(job.progress).Text(job.stage, "stage");
  p.Text(job.result_json, "result").Text(job.error, "error").Text(NowUtcIso8601(), "updated_at");
  p.Int(job.id).Text(owner, "owner").Text(job.machine_document, "machine_document");
  return c->Query(
              "UPDATE jobs SET status = $1, progress = $2, stage = $3, result_json = $4, "
              "error = $5, lease_until_ms = 0, updated_at = $6, machine_document = $9 "
              "WHERE id = $7 AND status = 'running' AND lease_owner = $8",
              p, "finish job")
             .Affected() == 1;
}

int PgStorage::ReleaseJobs(const std::string& owner) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(NowUtcIso8601(), "updated_at").Text(owner, "owner");
  return static_cast<int>(
      c->Query("UPDATE jobs SET status = 'queued', stage = 'waiting for an instance', "
               "lease_owner = '', lease_until_ms = 0, updated_at = $1 "
               "WHERE status = 'running' AND lease_owner = $2",
               p, "release jobs")
          .Affected());
}

bool PgStorage::CancelJob(JobId id, const std::string& reason) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(reason, "reason").Text(NowUtcIso8601(), "updated_at").Int(id);
  return c->Query(
              "UPDATE jobs SET status = 'cancelled', stage = 'cancelled', error = $1, "
              "lease_until_ms = 0, updated_at = $2 "
              "WHERE id = $3 AND status IN ('queued', 'running')",
              p, "cancel job")
             .Affected() == 1;
}

}  // namespace km::server
