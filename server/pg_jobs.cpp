// Background jobs in the PostgreSQL backend: table jobs (migration 2, with the job-queue
// columns of migration 8).
#include "server/pg_db.h"
#include "server/pg_storage.h"
#include "server/time_util.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;

constexpr const char* kJobColumns =
    "id, kind, status, progress, stage, request_json, result_json, error, created_at, updated_at";

JobRecord ReadJob(const Result& s, int row) {
  JobRecord j;
  j.id = s.Int(row, 0);
  j.kind = s.Text(row, 1);
  j.status = s.Text(row, 2);
  j.progress = s.Real(row, 3);
  j.stage = s.Text(row, 4);
  j.request_json = s.Text(row, 5);
  j.result_json = s.Text(row, 6);
  j.error = s.Text(row, 7);
  j.created_at = s.Text(row, 8);
  j.updated_at = s.Text(row, 9);
  return j;
}

}  // namespace

std::int64_t PgStorage::CreateJob(const std::string& kind, const std::string& request_json) {
  auto c = pool_->Acquire();
  const std::string now = NowUtcIso8601();
  Params p;
  p.Text(kind, "kind").Text(request_json, "request").Text(now, "created_at");
  return c
      ->Query(
          "INSERT INTO jobs (kind, status, request_json, created_at, updated_at) "
          "VALUES ($1, 'queued', $2, $3, $3) RETURNING id",
          p, "store job")
      .Int(0, 0);
}

void PgStorage::UpdateJob(const JobRecord& job) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(job.status, "status").Real(job.progress).Text(job.stage, "stage");
  p.Text(job.result_json, "result").Text(job.error, "error").Text(NowUtcIso8601(), "updated_at");
  p.Int(job.id);
  c->Query(
      "UPDATE jobs SET status = $1, progress = $2, stage = $3, result_json = $4, error = $5, "
      "updated_at = $6 WHERE id = $7",
      p, "update job");
}

std::optional<JobRecord> PgStorage::GetJob(std::int64_t id) {
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
  return static_cast<int>(c->Query("UPDATE jobs SET status = 'failed', error = $1, updated_at = $2 "
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

}  // namespace km::server
