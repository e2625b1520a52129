#include "server/storage/sqlite/sqlite_db.h"

#include <stdexcept>
#include <string_view>

#include "server/base/utf8.h"

namespace km::server::sqlite {

void Fail(sqlite3* db, int rc, const std::string& what) {
  const int code = rc & 0xff;
  std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  throw StorageError("storage: " + what + ": " + msg, code,
                     code == SQLITE_BUSY || code == SQLITE_LOCKED);
}

void Exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
  if (rc != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errstr(rc);
    sqlite3_free(err);
    const int code = rc & 0xff;
    throw StorageError("storage: " + msg, code, code == SQLITE_BUSY || code == SQLITE_LOCKED);
  }
}

Statement::Statement(sqlite3* db, const std::string& sql) : db_(db) {
  const int rc =
      sqlite3_prepare_v2(db, sql.c_str(), static_cast<int>(sql.size() + 1), &s_, nullptr);
  if (rc != SQLITE_OK) {
    sqlite3_finalize(s_);
    s_ = nullptr;
    Fail(db, rc, "prepare");
  }
}

Statement::~Statement() {
  sqlite3_finalize(s_);
}

Statement& Statement::Bind(int i, std::int64_t v) {
  Check(sqlite3_bind_int64(s_, i, v), "bind");
  return *this;
}

Statement& Statement::Bind(int i, const std::string& v) {
  Check(sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT), "bind");
  return *this;
}

Statement& Statement::Bind(int i, const std::optional<std::string>& v) {
  if (v) return Bind(i, *v);
  Check(sqlite3_bind_null(s_, i), "bind");
  return *this;
}

Statement& Statement::BindReal(int i, double v) {
  Check(sqlite3_bind_double(s_, i, v), "bind");
  return *this;
}

Statement& Statement::BindBlob(int i, const std::string& v) {
  Check(sqlite3_bind_blob64(s_, i, v.data(), v.size(), SQLITE_TRANSIENT), "bind");
  return *this;
}

void Statement::Reset() {
  sqlite3_reset(s_);
  sqlite3_clear_bindings(s_);
}

bool Statement::TryStep() {
  const int rc = sqlite3_step(s_);
  if (rc == SQLITE_DONE || rc == SQLITE_ROW) return true;
  if ((sqlite3_extended_errcode(db_) & 0xff) == SQLITE_CONSTRAINT) return false;
  Fail(db_, rc, "step");
}

bool Statement::Step() {
  const int rc = sqlite3_step(s_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  Fail(db_, rc, "step");
}

std::string Statement::Text(int c) const {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s_, c));
  return p ? SanitizeUtf8(
                 std::string_view(p, static_cast<std::size_t>(sqlite3_column_bytes(s_, c))))
           : "";
}

std::optional<std::string> Statement::OptText(int c) const {
  if (IsNull(c)) return std::nullopt;
  return Text(c);
}

std::string Statement::Blob(int c) const {
  const auto* p = static_cast<const char*>(sqlite3_column_blob(s_, c));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s_, c))) : "";
}

void Statement::Check(int rc, const char* what) {
  if (rc != SQLITE_OK) Fail(db_, rc, what);
}

CachedStatement::CachedStatement(StatementCache& cache, const std::string& sql) {
  auto& entry = cache.cache_[sql];
  if (entry.leased) throw std::logic_error("storage: statement leased twice: " + sql);
  if (!entry.statement) {
    try {
      entry.statement = std::make_unique<Statement>(cache.db_, sql);
    } catch (...) {
      cache.cache_.erase(sql);
      throw;
    }
  }
  entry.leased = true;
  entry_ = &entry;
}

CachedStatement::~CachedStatement() {
  entry_->statement->Reset();
  entry_->leased = false;
}

}  // namespace km::server::sqlite
