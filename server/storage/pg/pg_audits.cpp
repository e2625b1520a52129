// Accuracy audits in the PostgreSQL backend (migration 7): audit_configs, one row a machine
// (its rules and schedule, replaced when changed, with the last and next run), and
// audit_verdicts, appended (triggers refuse DELETE and any change but the webhook delivery).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;

constexpr const char* kConfigColumns =
    "machine_id, schedule, rules_json, updated_at, last_run_at, next_run_at";
constexpr const char* kVerdictColumns =
    "id, machine_id, level, run_trigger, created_at, verdict_json, webhook_status, "
    "webhook_attempts";

AuditConfigRecord ReadConfig(const Result& s, int i) {
  AuditConfigRecord c;
  c.machine_id = s.Text(i, 0);
  c.schedule = s.OptText(i, 1);
  c.rules_json = s.Text(i, 2);
  c.updated_at = s.Text(i, 3);
  c.last_run_at = s.OptText(i, 4);
  c.next_run_at = s.OptText(i, 5);
  return c;
}

AuditVerdictRecord ReadVerdict(const Result& s, int i) {
  AuditVerdictRecord v;
  v.id = AuditVerdictId(s.Int(i, 0));
  v.machine_id = s.Text(i, 1);
  v.level = static_cast<int>(s.Int(i, 2));
  v.trigger = s.Text(i, 3);
  v.created_at = s.Text(i, 4);
  v.verdict_json = s.Text(i, 5);
  v.webhook_status = s.Text(i, 6);
  v.webhook_attempts = s.Int(i, 7);
  return v;
}

}  // namespace

void PgStorage::PutAuditConfig(const AuditConfigRecord& cfg) {
  auto c = pool_->Acquire();
  Params p;
  p.Key(cfg.machine_id, "machine_id").Text(cfg.schedule, "schedule");
  p.Text(cfg.rules_json, "rules");
  p.Text(cfg.updated_at.empty() ? NowUtcIso8601() : cfg.updated_at, "updated_at");
  p.Text(cfg.last_run_at, "last_run_at").Text(cfg.next_run_at, "next_run_at");
  c->Query(
      "INSERT INTO audit_configs (machine_id, schedule, rules_json, updated_at, last_run_at, "
      "next_run_at) VALUES ($1, $2, $3, $4, $5, $6) ON CONFLICT (machine_id) DO UPDATE SET "
      "schedule = excluded.schedule, rules_json = excluded.rules_json, "
      "updated_at = excluded.updated_at, last_run_at = excluded.last_run_at, "
      "next_run_at = excluded.next_run_at",
      p, "store audit config");
}

std::optional<AuditConfigRecord> PgStorage::GetAuditConfig(const std::string& machine_id) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(machine_id, "machine_id");
  const Result r = c->Query(
      std::string("SELECT ") + kConfigColumns + " FROM audit_configs WHERE machine_id = $1", p,
      "read audit config");
  if (r.Rows() == 0) return std::nullopt;
  return ReadConfig(r, 0);
}

std::vector<AuditConfigRecord> PgStorage::ListAuditConfigs() {
  auto c = pool_->Acquire();
  const Result r =
      c->Query(std::string("SELECT ") + kConfigColumns + " FROM audit_configs ORDER BY machine_id",
               "list audit configs");
  std::vector<AuditConfigRecord> out;
  for (int i = 0; i < r.Rows(); ++i) out.push_back(ReadConfig(r, i));
  return out;
}

void PgStorage::SetAuditRun(const std::string& machine_id, const std::optional<std::string>& last,
                            const std::optional<std::string>& next) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(last, "last_run_at").Text(next, "next_run_at").Text(machine_id, "machine_id");
  c->Query(
      "UPDATE audit_configs SET last_run_at = COALESCE($1, last_run_at), next_run_at = $2 "
      "WHERE machine_id = $3",
      p, "record audit run");
}

bool PgStorage::ClaimAuditRun(const std::string& machine_id, const std::string& due,
                              const std::string& last, const std::optional<std::string>& next) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(last, "last_run_at").Text(next, "next_run_at").Text(machine_id, "machine_id");
  p.Text(due, "due");
  // A second instance's update waits for the first's row lock, then finds next_run_at moved.
  return c->Query(
              "UPDATE audit_configs SET last_run_at = $1, next_run_at = $2 "
              "WHERE machine_id = $3 AND next_run_at = $4",
              p, "claim audit run")
             .Affected() == 1;
}

AuditVerdictId PgStorage::AddAuditVerdict(const AuditVerdictRecord& v) {
  auto c = pool_->Acquire();
  Params p;
  p.Key(v.machine_id, "machine_id").Int(v.level).Text(v.trigger, "trigger");
  p.Text(v.created_at.empty() ? NowUtcIso8601() : v.created_at, "created_at");
  p.Text(v.verdict_json, "verdict").Text(v.webhook_status, "webhook_status");
  p.Int(v.webhook_attempts);
  return AuditVerdictId(
      c->Query(
           "INSERT INTO audit_verdicts (machine_id, level, run_trigger, created_at, "
           "verdict_json, webhook_status, webhook_attempts) VALUES ($1, $2, $3, $4, $5, $6, $7) "
           "RETURNING id",
           p, "store audit verdict")
          .Int(0, 0));
}

std::optional<AuditVerdictRecord> PgStorage::GetAuditVerdict(AuditVerdictId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r =
      c->Query(std::string("SELECT ") + kVerdictColumns + " FROM audit_verdicts WHERE id = $1", p,
               "read audit verdict");
  if (r.Rows() == 0) return std::nullopt;
  return ReadVerdict(r, 0);
}

// A page of verdicts, newest first; with max_bytes only those whose predecessors on the page
// hold at most max_bytes of verdict_json (counted by the server, so the rest is never sent).
std::vector<AuditVerdictRecord> PgStorage::ListAuditVerdicts(const AuditVerdictFilter& f) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(f.machine_id, "machine_id").Text(f.from, "from").Text(f.to, "to");
  if (f.limit < 0) {
    p.Null();
  } else {
    p.Int(f.limit);
  }
  p.Int(f.offset);
  if (f.max_bytes) {
    p.Int(*f.max_bytes);
  } else {
    p.Null();
  }
  const std::string cols = kVerdictColumns;
  const Result r = c->Query(
      "SELECT " + cols + " FROM (SELECT " + cols +
          ", COALESCE(SUM(octet_length(verdict_json)) OVER (ORDER BY created_at DESC, id DESC "
          "ROWS BETWEEN UNBOUNDED PRECEDING AND 1 PRECEDING), 0) AS bytes_before FROM (SELECT " +
          cols +
          " FROM audit_verdicts WHERE ($1::TEXT IS NULL OR machine_id = $1) "
          "AND ($2::TEXT IS NULL OR created_at >= $2) AND ($3::TEXT IS NULL OR created_at < $3) "
          "ORDER BY created_at DESC, id DESC LIMIT $4 OFFSET $5) page) listed "
          "WHERE $6::BIGINT IS NULL OR bytes_before <= $6 ORDER BY created_at DESC, id DESC",
      p, "list audit verdicts");
  std::vector<AuditVerdictRecord> out;
  for (int i = 0; i < r.Rows(); ++i) out.push_back(ReadVerdict(r, i));
  return out;
}

void PgStorage::SetAuditWebhook(AuditVerdictId id, const std::string& status,
                                std::int64_t attempts) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(status, "webhook_status").Int(attempts).Int(id);
  c->Query("UPDATE audit_verdicts SET webhook_status = $1, webhook_attempts = $2 WHERE id = $3", p,
           "record webhook delivery");
}

}  // namespace km::server
