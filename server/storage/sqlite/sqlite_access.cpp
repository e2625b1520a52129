// Access tokens and the audit log in the SQLite backend: table tokens (migration 1, with name,
// expiry and revocation from migration 6, last use from migration 10) and audit_log (migration 6,
// appended only: triggers refuse UPDATE and DELETE).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

using sqlite::Statement;

constexpr const char* kTokenColumns =
    "id, role, label, created_at, expires_at, revoked_at, last_used_at";

TokenRecord ReadToken(const Statement& s) {
  TokenRecord t;
  t.id = TokenId(s.Int(0));
  t.role = s.Text(1);
  t.name = s.Text(2);
  t.created_at = s.Text(3);
  t.expires_at = s.OptText(4);
  t.revoked_at = s.OptText(5);
  t.last_used_at = s.OptText(6);
  return t;
}

}  // namespace

TokenId SqliteStorage::AddToken(const std::string& token_sha256, const std::string& role,
                                const std::string& name,
                                const std::optional<std::string>& expires_at) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO tokens (token_sha256, role, label, created_at, expires_at) "
      "VALUES (?, ?, ?, ?, ?)");
  s->Bind(1, token_sha256).Bind(2, role).Bind(3, name).Bind(4, NowUtcIso8601());
  s->Bind(5, expires_at);
  s->Step();
  return TokenId(sqlite3_last_insert_rowid(db_));
}

std::optional<TokenRecord> SqliteStorage::FindToken(const std::string& token_sha256) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kTokenColumns + " FROM tokens WHERE token_sha256 = ?");
  s->Bind(1, token_sha256);
  if (!s->Step()) return std::nullopt;
  return ReadToken(*s);
}

std::vector<TokenRecord> SqliteStorage::ListTokens() {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kTokenColumns + " FROM tokens ORDER BY id");
  std::vector<TokenRecord> out;
  while (s->Step()) out.push_back(ReadToken(*s));
  return out;
}

bool SqliteStorage::RevokeToken(TokenId id, const TokensCheck& check) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);  // BEGIN IMMEDIATE: also other processes on the file wait
  std::vector<TokenRecord> tokens;
  {
    auto all = Prepared(std::string("SELECT ") + kTokenColumns + " FROM tokens ORDER BY id");
    while (all->Step()) tokens.push_back(ReadToken(*all));
  }
  check(tokens);
  auto s = Prepared("UPDATE tokens SET revoked_at = COALESCE(revoked_at, ?) WHERE id = ?");
  s->Bind(1, NowUtcIso8601()).Bind(2, id);
  s->Step();
  const bool changed = sqlite3_changes(db_) > 0;
  tx.Commit();
  return changed;
}

void SqliteStorage::TouchToken(TokenId id, const std::string& at) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "UPDATE tokens SET last_used_at = ? WHERE id = ? AND (last_used_at IS NULL OR "
      "last_used_at < ?)");
  s->Bind(1, at).Bind(2, id).Bind(3, at);
  s->Step();
}

void SqliteStorage::AppendAudit(const AuditEntry& e) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO audit_log (at, token_id, token_name, role, method, path, status, subject) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?)");
  s->Bind(1, e.at.empty() ? NowUtcIso8601() : e.at);
  if (e.token_id) s->Bind(2, *e.token_id);
  s->Bind(3, e.token_name).Bind(4, e.role).Bind(5, e.method).Bind(6, e.path);
  s->Bind(7, static_cast<std::int64_t>(e.status)).Bind(8, e.subject);
  s->Step();
}

AuditPage SqliteStorage::ListAudit(std::int64_t limit, std::int64_t offset) {
  std::lock_guard lock(mu_);
  AuditPage page;
  {
    auto s = Prepared("SELECT COUNT(*) FROM audit_log");
    page.total = s->Step() ? s->Int(0) : 0;
  }
  auto s = Prepared(
      "SELECT id, at, token_id, token_name, role, method, path, status, subject FROM audit_log "
      "ORDER BY id DESC LIMIT ? OFFSET ?");
  s->Bind(1, limit).Bind(2, offset);
  while (s->Step()) {
    AuditEntry e;
    e.id = AuditEntryId(s->Int(0));
    e.at = s->Text(1);
    e.token_id = s->IsNull(2) ? std::nullopt : IdOrNone<TokenId>(s->Int(2));
    e.token_name = s->Text(3);
    e.role = s->Text(4);
    e.method = s->Text(5);
    e.path = s->Text(6);
    e.status = static_cast<int>(s->Int(7));
    e.subject = s->Text(8);
    page.items.push_back(std::move(e));
  }
  return page;
}

}  // namespace km::server
