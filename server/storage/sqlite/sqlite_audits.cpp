// Accuracy audits in the SQLite backend (migration 7): audit_configs, one row a machine (its
// rules and schedule, replaced when changed, with the last and next run), and audit_verdicts,
// appended (a trigger refuses DELETE; only the webhook delivery status of a verdict changes).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

using sqlite::Statement;

constexpr const char* kConfigColumns =
    "machine_id, schedule, rules_json, updated_at, last_run_at, next_run_at";
constexpr const char* kVerdictColumns =
    "id, machine_id, level, run_trigger, created_at, verdict_json, webhook_status, "
    "webhook_attempts";

AuditConfigRecord ReadConfig(const Statement& s) {
  AuditConfigRecord c;
  c.machine_id = s.Text(0);
  c.schedule = s.OptText(1);
  c.rules_json = s.Text(2);
  c.updated_at = s.Text(3);
  c.last_run_at = s.OptText(4);
  c.next_run_at = s.OptText(5);
  return c;
}

AuditVerdictRecord ReadVerdict(const Statement& s) {
  AuditVerdictRecord v;
  v.id = AuditVerdictId(s.Int(0));
  v.machine_id = s.Text(1);
  v.level = static_cast<int>(s.Int(2));
  v.trigger = s.Text(3);
  v.created_at = s.Text(4);
  v.verdict_json = s.Text(5);
  v.webhook_status = s.Text(6);
  v.webhook_attempts = s.Int(7);
  return v;
}

}  // namespace

void SqliteStorage::PutAuditConfig(const AuditConfigRecord& c) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO audit_configs (machine_id, schedule, rules_json, updated_at, last_run_at, "
      "next_run_at) VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT(machine_id) DO UPDATE SET "
      "schedule = excluded.schedule, rules_json = excluded.rules_json, "
      "updated_at = excluded.updated_at, last_run_at = excluded.last_run_at, "
      "next_run_at = excluded.next_run_at");
  s->Bind(1, c.machine_id).Bind(2, c.schedule).Bind(3, c.rules_json);
  s->Bind(4, c.updated_at.empty() ? NowUtcIso8601() : c.updated_at);
  s->Bind(5, c.last_run_at).Bind(6, c.next_run_at);
  s->Step();
}

std::optional<AuditConfigRecord> SqliteStorage::GetAuditConfig(const std::string& machine_id) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kConfigColumns +
                    " FROM audit_configs WHERE machine_id = ?");
  s->Bind(1, machine_id);
  if (!s->Step()) return std::nullopt;
  return ReadConfig(*s);
}

std::vector<AuditConfigRecord> SqliteStorage::ListAuditConfigs() {
  std::lock_guard lock(mu_);
  auto s =
      Prepared(std::string("SELECT ") + kConfigColumns + " FROM audit_configs ORDER BY machine_id");
  std::vector<AuditConfigRecord> out;
  while (s->Step()) out.push_back(ReadConfig(*s));
  return out;
}

void SqliteStorage::SetAuditRun(const std::string& machine_id,
                                const std::optional<std::string>& last,
                                const std::optional<std::string>& next) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE audit_configs SET last_run_at = COALESCE(?, last_run_at), next_run_at = ? "
      "WHERE machine_id = ?");
  s->Bind(1, last).Bind(2, next).Bind(3, machine_id);
  s->Step();
}

bool SqliteStorage::ClaimAuditRun(const std::string& machine_id, const std::string& due,
                                  const std::string& last, const std::optional<std::string>& next) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE audit_configs SET last_run_at = ?, next_run_at = ? "
      "WHERE machine_id = ? AND next_run_at = ?");
  s->Bind(1, last).Bind(2, next).Bind(3, machine_id).Bind(4, due);
  s->Step();
  return sqlite3_changes(db_) == 1;
}

AuditVerdictId SqliteStorage::AddAuditVerdict(const AuditVerdictRecord& v) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO audit_verdicts (machine_id, level, run_trigger, created_at, verdict_json, "
      "webhook_status, webhook_attempts) VALUES (?, ?, ?, ?, ?, ?, ?)");
  s->Bind(1, v.machine_id).Bind(2, static_cast<std::int64_t>(v.level)).Bind(3, v.trigger);
  s->Bind(4, v.created_at.empty() ? NowUtcIso8601() : v.created_at).Bind(5, v.verdict_json);
  s->Bind(6, v.webhook_status).Bind(7, v.webhook_attempts);
  s->Step();
  return AuditVerdictId(sqlite3_last_insert_rowid(db_));
}

std::optional<AuditVerdictRecord> SqliteStorage::GetAuditVerdict(AuditVerdictId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kVerdictColumns + " FROM audit_verdicts WHERE id = ?");
  s->Bind(1, id);
  if (!s->Step()) return std::nullopt;
  return ReadVerdict(*s);
}

std::vector<AuditVerdictRecord> SqliteStorage::ListAuditVerdicts(const AuditVerdictFilter& f) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kVerdictColumns +
                    " FROM audit_verdicts WHERE (?1 IS NULL OR machine_id = ?1) AND "
                    "(?2 IS NULL OR created_at >= ?2) AND (?3 IS NULL OR created_at < ?3) "
                    "ORDER BY created_at DESC, id DESC LIMIT ?4 OFFSET ?5");
  s->Bind(1, f.machine_id).Bind(2, f.from).Bind(3, f.to).Bind(4, f.limit).Bind(5, f.offset);
  std::vector<AuditVerdictRecord> out;
  std::int64_t bytes = 0;  // rows are read one at a time: the rest is never loaded
  while ((!f.max_bytes || bytes <= *f.max_bytes) && s->Step()) {
    out.push_back(ReadVerdict(*s));
    bytes += static_cast<std::int64_t>(out.back().verdict_json.size());
  }
  return out;
}

void SqliteStorage::SetAuditWebhook(AuditVerdictId id, const std::string& status,
                                    std::int64_t attempts) {
  std::lock_guard lock(mu_);
  auto s =
      Prepared("UPDATE audit_verdicts SET webhook_status = ?, webhook_attempts = ? WHERE id = ?");
  s->Bind(1, status).Bind(2, attempts).Bind(3, id);
  s->Step();
}

}  // namespace km::server
