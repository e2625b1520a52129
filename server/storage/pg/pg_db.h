// Internal to the PostgreSQL backend (server/pg_*.cpp): the thin layer over libpq that the
// data-access files are written in. Not part of the storage interface.
//
//  * every failure is a StorageError "storage: <what>: <PostgreSQL's message>" whose code() is
//    the SQLSTATE read as a base-36 number (SqlStateCode("40001")); busy() is true for
//    serialization failures (40001), deadlocks (40P01), lock and statement timeouts (55P03,
//    57014), a lost connection (class 08) and a server shutting down (57P0x): the API answers
//    503 with Retry-After;
//  * values are always sent as parameters (never spliced into SQL): text, integers and
//    doubles in text form, bytea in binary form; text is made valid UTF-8 (what the SQLite
//    backend answers for the same bytes) and a NUL byte, which PostgreSQL text cannot hold, is
//    refused as InvalidInput naming the field;
//  * Pool: up to `size` connections, opened when needed; a lease waits (at most the busy
//    timeout) for a free one. A connection found broken (the server restarted) is opened again
//    on its next lease, so the process outlives a PostgreSQL restart;
//  * each distinct SQL text is prepared once per connection and reused;
//  * Transaction: BEGIN, rolled back by the destructor unless Commit() was called.
#pragma once

#include <libpq-fe.h>

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "server/storage/storage.h"

namespace km::server::pg {

// The SQLSTATE (five characters of 0-9A-Z) as a base-36 number: StorageError::code().
int SqlStateCode(const std::string& sqlstate);

// Parameters of one statement.
class Params {
 public:
  Params& Int(std::int64_t v);
  template <class Tag>
  Params& Int(Id<Tag> id) {  // a table's id, as its integer key
    return Int(id.value());
  }
  Params& Real(double v);
  // `field` names the value in the InvalidInput of a NUL byte.
  Params& Text(const std::string& v, const char* field);
  Params& Text(const std::optional<std::string>& v, const char* field);  // NULL when empty
  // Text that goes into a B-tree index (machine ids): at most kMaxKeyBytes, or InvalidInput
  // naming the field (PostgreSQL cannot index longer entries; SQLite keeps them).
  Params& Key(const std::string& v, const char* field);
  static constexpr std::size_t kMaxKeyBytes = 2048;
  Params& Bytes(const std::string& v);  // bytea, exact bytes
  Params& Null();

  int size() const { return static_cast<int>(values_.size()); }
  const char* const* values() const { return values_.data(); }
  const int* lengths() const { return lengths_.data(); }
  const int* formats() const { return formats_.data(); }

 private:
  Params& Add(std::string v, int format, bool null = false);
  std::vector<std::unique_ptr<std::string>> held_;
  std::vector<const char*> values_;
  std::vector<int> lengths_;
  std::vector<int> formats_;
};

// A result set; getters by row and column. Text columns come back as stored, integer and
// double columns parsed, bytea unescaped (or raw in a binary result).
class Result {
 public:
  explicit Result(PGresult* r) : r_(r) {}
  int Rows() const { return PQntuples(r_.get()); }
  std::int64_t Affected() const;
  bool IsNull(int row, int c) const { return PQgetisnull(r_.get(), row, c) != 0; }
  std::int64_t Int(int row, int c) const;
  double Real(int row, int c) const;
  std::string Text(int row, int c) const;
  std::optional<std::string> OptText(int row, int c) const;
  std::string Bytes(int row, int c) const;

 private:
  struct Free {
    void operator()(PGresult* r) const { PQclear(r); }
  };
  std::unique_ptr<PGresult, Free> r_;
};

struct ConnOptions {
  std::string url;               // postgresql://… or postgres://…
  int busy_timeout_ms = 5000;    // lock_timeout, and the longest wait for a free connection
  int statement_timeout_ms = 0;  // 0: none
};

// One connection and its prepared statements.
class Conn {
 public:
  Conn(const ConnOptions& options);
  ~Conn();
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;

  // Runs SQL without parameters (schema, transaction control); several statements allowed.
  void Exec(const std::string& sql, const std::string& what);
  // Runs a statement (prepared once per connection); `binary` asks for binary results (for
  // bytea without the hex round trip; only bytea, text and integer columns then).
  Result Query(const std::string& sql, const Params& params, const std::string& what,
               bool binary = false);
  Result Query(const std::string& sql, const std::string& what) { return Query(sql, {}, what); }
  // Query, but nullopt when a constraint (unique, foreign key, check: SQLSTATE class 23)
  // refused the statement (the transaction, if any, is then aborted).
  std::optional<Result> TryQuery(const std::string& sql, const Params& params,
                                 const std::string& what);
  // false when the server closed the connection (a restart) or it failed.
  bool Healthy();
  PGconn* raw() { return c_; }

 private:
  [[noreturn]] void Fail(const PGresult* r, const std::string& what);
  PGconn* c_ = nullptr;
  std::unordered_map<std::string, std::string> prepared_;  // SQL → statement name
};

class Pool;

// A connection of the pool, leased for one call.
class Lease {
 public:
  Lease(Pool& pool, std::unique_ptr<Conn> conn) : pool_(&pool), conn_(std::move(conn)) {}
  ~Lease();
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
  Conn* operator->() { return conn_.get(); }
  Conn& operator*() { return *conn_; }

 private:
  Pool* pool_;
  std::unique_ptr<Conn> conn_;
};

class Pool {
 public:
  Pool(ConnOptions options, int size);
  // A connection: an idle healthy one, else a new one while fewer than size are open; waits
  // up to the busy timeout otherwise (then a busy StorageError).
  Lease Acquire();
  // Opens connections until `size` are open, so that the first requests of a busy start do not
  // each wait for a connection to be made. Best effort: stops at the first that fails (an
  // Acquire then tries again).
  void Fill();

 private:
  friend class Lease;
  void Return(std::unique_ptr<Conn> conn);
  ConnOptions options_;
  int size_;
  int open_ = 0;  // idle + leased
  std::vector<std::unique_ptr<Conn>> idle_;
  std::mutex mu_;
  std::condition_variable freed_;
};

// Rolls back unless Commit() was called.
class Transaction {
 public:
  explicit Transaction(Conn& c) : c_(c) { c_.Exec("BEGIN", "begin"); }
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void Commit() {
    c_.Exec("COMMIT", "commit");
    done_ = true;
  }

 private:
  Conn& c_;
  bool done_ = false;
};

}  // namespace km::server::pg
