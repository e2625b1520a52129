// Access tokens and the audit log in the PostgreSQL backend: table tokens (migration 1, with
// name, expiry and revocation from migration 6, last use from migration 10) and audit_log
// (migration 6, appended only: triggers refuse UPDATE and DELETE).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;

constexpr const char* kTokenColumns =
    "id, role, label, created_at, expires_at, revoked_at, last_used_at";

TokenRecord ReadToken(const Result& s, int i) {
  TokenRecord t;
  t.id = TokenId(s.Int(i, 0));
  t.role = s.Text(i, 1);
  t.name = s.Text(i, 2);
  t.created_at = s.Text(i, 3);
  t.expires_at = s.OptText(i, 4);
  t.revoked_at = s.OptText(i, 5);
  t.last_used_at = s.OptText(i, 6);
  return t;
}

}  // namespace

TokenId PgStorage::AddToken(const std::string& token_sha256, const std::string& role,
                            const std::string& name, const std::optional<std::string>& expires_at) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(token_sha256, "token").Text(role, "role").Text(name, "name");
  p.Text(NowUtcIso8601(), "created_at").Text(expires_at, "expires_at");
  return TokenId(c->Query("INSERT INTO tokens (token_sha256, role, label, created_at, expires_at) "
                          "VALUES ($1, $2, $3, $4, $5) RETURNING id",
                          p, "store token")
                     .Int(0, 0));
}

std::optional<TokenRecord> PgStorage::FindToken(const std::string& token_sha256) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(token_sha256, "token");
  const Result r =
      c->Query(std::string("SELECT ") + kTokenColumns + " FROM tokens WHERE token_sha256 = $1", p,
               "find token");
  if (r.Rows() == 0) return std::nullopt;
  return ReadToken(r, 0);
}

std::vector<TokenRecord> PgStorage::ListTokens() {
  auto c = pool_->Acquire();
  const Result r =
      c->Query(std::string("SELECT ") + kTokenColumns + " FROM tokens ORDER BY id", "list tokens");
  std::vector<TokenRecord> out;
  for (int i = 0; i < r.Rows(); ++i) out.push_back(ReadToken(r, i));
  return out;
}

bool PgStorage::RevokeToken(TokenId id, const TokensCheck& check) {
  auto c = pool_->Acquire();
  pg::Transaction tx(*c);
  // Revocations of every instance take turns (the lock conflicts with itself); reads go on.
  c->Exec("LOCK TABLE tokens IN SHARE ROW EXCLUSIVE MODE", "lock tokens");
  const Result all =
      c->Query(std::string("SELECT ") + kTokenColumns + " FROM tokens ORDER BY id", "list tokens");
  std::vector<TokenRecord> tokens;
  for (int i = 0; i < all.Rows(); ++i) tokens.push_back(ReadToken(all, i));
  check(tokens);
  Params p;
  p.Text(NowUtcIso8601(), "revoked_at").Int(id);
  const bool changed =
      c->Query("UPDATE tokens SET revoked_at = COALESCE(revoked_at, $1) WHERE id = $2", p,
               "revoke token")
          .Affected() > 0;
  tx.Commit();
  return changed;
}

void PgStorage::TouchToken(TokenId id, const std::string& at) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(at, "last_used_at").Int(id);
  c->Query(
      "UPDATE tokens SET last_used_at = $1 WHERE id = $2 AND (last_used_at IS NULL OR "
      "last_used_at < $1)",
      p, "record token use");
}

void PgStorage::AppendAudit(const AuditEntry& e) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(e.at.empty() ? NowUtcIso8601() : e.at, "at");
  if (e.token_id) {
    p.Int(*e.token_id);
  } else {
    p.Null();
  }
  p.Text(e.token_name, "token_name").Text(e.role, "role").Text(e.method, "method");
  p.Text(e.path, "path").Int(e.status).Text(e.subject, "subject");
  c->Query(
      "INSERT INTO audit_log (at, token_id, token_name, role, method, path, status, subject) "
      "VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
      p, "append audit entry");
}

AuditPage PgStorage::ListAudit(std::int64_t limit, std::int64_t offset) {
  auto c = pool_->Acquire();
  AuditPage page;
  page.total = c->Query("SELECT COUNT(*) FROM audit_log", "count audit entries").Int(0, 0);
  Params p;
  if (limit < 0) {
    p.Null();
  } else {
    p.Int(limit);
  }
  p.Int(std::max<std::int64_t>(0, offset));
  const Result s = c->Query(
      "SELECT id, at, token_id, token_name, role, method, path, status, subject FROM audit_log "
      "ORDER BY id DESC LIMIT $1 OFFSET $2",
      p, "list audit entries");
  for (int i = 0; i < s.Rows(); ++i) {
    AuditEntry e;
    e.id = AuditEntryId(s.Int(i, 0));
    e.at = s.Text(i, 1);
    e.token_id = s.IsNull(i, 2) ? std::nullopt : IdOrNone<TokenId>(s.Int(i, 2));
    e.token_name = s.Text(i, 3);
    e.role = s.Text(i, 4);
    e.method = s.Text(i, 5);
    e.path = s.Text(i, 6);
    e.status = static_cast<int>(s.Int(i, 7));
    e.subject = s.Text(i, 8);
    page.items.push_back(std::move(e));
  }
  return page;
}

}  // namespace km::server
