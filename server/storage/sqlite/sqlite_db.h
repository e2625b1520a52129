// Internal to the SQLite backend (server/sqlite_*.cpp): the thin layer over the SQLite C API
// that the data-access files are written in. Not part of the storage interface.
//
//  * every failure is a StorageError carrying SQLite's primary result code (SQLITE_BUSY and
//    SQLITE_LOCKED mark it busy: the API answers 503 with Retry-After);
//  * Statement: a prepared statement, finalised by its destructor, with typed Bind and column
//    getters (text read back is made valid UTF-8);
//  * StatementCache: each distinct SQL text is prepared once per connection and reused; a
//    CachedStatement lease resets it (and clears its bindings) when the lease ends, so no
//    statement keeps a read transaction open;
//  * Transaction: BEGIN IMMEDIATE, rolled back by the destructor unless Commit() was called.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>

#include "server/storage/storage.h"

namespace km::server::sqlite {

// The StorageError of a failed call: "storage: <what>: <SQLite's message>" and the code of rc.
[[noreturn]] void Fail(sqlite3* db, int rc, const std::string& what);

// Runs SQL without results (schema, pragmas, transaction control).
void Exec(sqlite3* db, const char* sql);

class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int i, std::int64_t v);
  template <class Tag>
  Statement& Bind(int i, Id<Tag> id) {  // a table's id, as its integer key
    return Bind(i, id.value());
  }
  Statement& Bind(int i, const std::string& v);
  Statement& Bind(int i, const std::optional<std::string>& v);  // NULL when empty
  Statement& BindReal(int i, double v);
  Statement& BindBlob(int i, const std::string& v);
  // Ready for new bindings (reuse of a prepared statement).
  void Reset();
  // Steps an INSERT; false when a UNIQUE constraint refused the row.
  bool TryStep();
  // true while a row is available.
  bool Step();

  std::int64_t Int(int c) const { return sqlite3_column_int64(s_, c); }
  double Real(int c) const { return sqlite3_column_double(s_, c); }
  bool IsNull(int c) const { return sqlite3_column_type(s_, c) == SQLITE_NULL; }
  // Text as stored, made valid UTF-8 (rows written before uploads were checked may hold other
  // bytes; everything read here may end up in JSON).
  std::string Text(int c) const;
  std::optional<std::string> OptText(int c) const;
  std::string Blob(int c) const;

 private:
  void Check(int rc, const char* what);
  sqlite3* db_;
  sqlite3_stmt* s_ = nullptr;
};

class CachedStatement;

// The prepared statements of one connection, by SQL text. Used under the connection's lock.
class StatementCache {
 public:
  explicit StatementCache(sqlite3* db) : db_(db) {}
  // Finalises every statement (before the connection closes).
  void Clear() { cache_.clear(); }

 private:
  friend class CachedStatement;
  struct Entry {
    std::unique_ptr<Statement> statement;
    bool leased = false;
  };
  sqlite3* db_;
  std::unordered_map<std::string, Entry> cache_;
};

// A statement of the cache, leased for one use: prepared on first use, reset when the lease
// ends. The same SQL may not be leased twice at once (a programming error: std::logic_error).
class CachedStatement {
 public:
  CachedStatement(StatementCache& cache, const std::string& sql);
  ~CachedStatement();
  CachedStatement(const CachedStatement&) = delete;
  CachedStatement& operator=(const CachedStatement&) = delete;
  Statement* operator->() { return entry_->statement.get(); }
  Statement& operator*() { return *entry_->statement; }

 private:
  StatementCache::Entry* entry_;
};

// Rolls back unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(sqlite3* db) : db_(db) { Exec(db_, "BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (!done_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit() {
    Exec(db_, "COMMIT");
    done_ = true;
  }

 private:
  sqlite3* db_;
  bool done_ = false;
};

}  // namespace km::server::sqlite
