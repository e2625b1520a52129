#include "server/storage/pg/pg_db.h"

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <poll.h>

#include "analysis/core/errors.h"
#include "server/base/database_url.h"
#include "server/base/utf8.h"

namespace km::server::pg {
namespace {

// libpq's message on one line: its lines joined with "; ", trailing blanks dropped.
std::string OneLine(const std::string& text) {
  std::string out;
  bool newline = false;
  for (const char ch : text) {
    if (ch == '\n') {
      newline = true;
    } else if (newline && (ch == '\t' || ch == ' ')) {
      continue;
    } else {
      if (newline && !out.empty()) out += "; ";
      newline = false;
      out += ch;
    }
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

// A failed call's StorageError; r (may be null) is cleared here.
[[noreturn]] void Throw(PGconn* c, PGresult* r, const std::string& what) {
  // PostgreSQL's primary message (and its detail), without severity and context lines.
  const char* primary = r ? PQresultErrorField(r, PG_DIAG_MESSAGE_PRIMARY) : nullptr;
  const char* detail = r ? PQresultErrorField(r, PG_DIAG_MESSAGE_DETAIL) : nullptr;
  std::string msg = primary ? primary : "";
  if (primary && detail) msg += std::string(" (") + detail + ")";
  if (msg.empty() && r) msg = PQresultErrorMessage(r);
  if (msg.empty() && c) msg = PQerrorMessage(c);
  msg = OneLine(msg);
  const char* state = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
  std::string sqlstate = state ? state : "";
  if (r) PQclear(r);
  if (sqlstate.empty() && (!c || PQstatus(c) == CONNECTION_BAD)) sqlstate = "08006";
  if (sqlstate.empty()) sqlstate = "XX000";
  const bool busy = sqlstate == "40001" || sqlstate == "40P01" || sqlstate == "55P03" ||
                    sqlstate == "57014" || sqlstate.rfind("08", 0) == 0 ||
                    sqlstate.rfind("57P0", 0) == 0;
  throw StorageError("storage: " + what + ": " + msg, SqlStateCode(sqlstate), busy);
}

bool Ok(const PGresult* r) {
  const auto status = PQresultStatus(r);
  return status == PGRES_TUPLES_OK || status == PGRES_COMMAND_OK;
}

std::int64_t BigEndian(const char* p, int len) {
  std::uint64_t v = 0;
  for (int i = 0; i < len; ++i) v = (v << 8) | static_cast<unsigned char>(p[i]);
  if (len < 8 && len > 0 && (static_cast<unsigned char>(p[0]) & 0x80)) {
    v |= ~std::uint64_t{0} << (8 * len);  // sign-extend int2 / int4
  }
  return static_cast<std::int64_t>(v);
}

}  // namespace

int SqlStateCode(const std::string& sqlstate) {
  int code = 0;
  for (const char ch : sqlstate) {
    const int d = ch >= '0' && ch <= '9' ? ch - '0' : ch >= 'A' && ch <= 'Z' ? ch - 'A' + 10 : 0;
    code = code * 36 + d;
  }
  return code;
}

Params& Params::Add(std::string v, int format, bool null) {
  held_.push_back(std::make_unique<std::string>(std::move(v)));
  values_.push_back(null ? nullptr : held_.back()->data());
  lengths_.push_back(static_cast<int>(held_.back()->size()));
  formats_.push_back(format);
  return *this;
}

Params& Params::Int(std::int64_t v) {
  return Add(std::to_string(v), 0);
}

Params& Params::Real(double v) {
  if (std::isnan(v)) return Add("NaN", 0);
  if (std::isinf(v)) return Add(v > 0 ? "Infinity" : "-Infinity", 0);
  char buf[32];
  const auto end = std::to_chars(buf, buf + sizeof buf, v).ptr;
  return Add(std::string(buf, end), 0);
}

Params& Params::Text(const std::string& v, const char* field) {
  if (std::memchr(v.data(), '\0', v.size())) {
    throw InvalidInput("", 0, field, "holds a NUL byte, which cannot be stored");
  }
  return Add(IsValidUtf8(v) ? v : SanitizeUtf8(v), 0);
}

Params& Params::Key(const std::string& v, const char* field) {
  if (v.size() > kMaxKeyBytes) {
    throw InvalidInput("", 0, field,
                       "is longer than " + std::to_string(kMaxKeyBytes) +
                           " bytes, the most the PostgreSQL database indexes");
  }
  return Text(v, field);
}

Params& Params::Text(const std::optional<std::string>& v, const char* field) {
  return v ? Text(*v, field) : Null();
}

Params& Params::Bytes(const std::string& v) {
  return Add(v, 1);
}

Params& Params::Null() {
  return Add("", 0, true);
}

std::int64_t Result::Affected() const {
  return std::atoll(PQcmdTuples(r_.get()));
}

std::int64_t Result::Int(int row, int c) const {
  const char* p = PQgetvalue(r_.get(), row, c);
  if (PQfformat(r_.get(), c) == 1) return BigEndian(p, PQgetlength(r_.get(), row, c));
  return std::strtoll(p, nullptr, 10);
}

double Result::Real(int row, int c) const {
  const char* p = PQgetvalue(r_.get(), row, c);
  if (PQfformat(r_.get(), c) == 1) {
    const auto bits = static_cast<std::uint64_t>(BigEndian(p, 8));
    double v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  return std::strtod(p, nullptr);
}

std::string Result::Text(int row, int c) const {
  return std::string(PQgetvalue(r_.get(), row, c),
                     static_cast<std::size_t>(PQgetlength(r_.get(), row, c)));
}

std::optional<std::string> Result::OptText(int row, int c) const {
  if (IsNull(row, c)) return std::nullopt;
  return Text(row, c);
}

std::string Result::Bytes(int row, int c) const {
  if (PQfformat(r_.get(), c) == 1) return Text(row, c);
  std::size_t n = 0;
  unsigned char* p =
      PQunescapeBytea(reinterpret_cast<const unsigned char*>(PQgetvalue(r_.get(), row, c)), &n);
  if (!p) throw StorageError("storage: read bytea: out of memory", SqlStateCode("53200"), false);
  std::string out(reinterpret_cast<const char*>(p), n);
  PQfreemem(p);
  return out;
}

Conn::Conn(const ConnOptions& o) {
  const std::string timeout = std::to_string(std::max(1, (o.busy_timeout_ms + 999) / 1000));
  const std::string options = "-c lock_timeout=" + std::to_string(o.busy_timeout_ms) +
                              " -c statement_timeout=" + std::to_string(o.statement_timeout_ms);
  const char* keys[] = {"connect_timeout",  "dbname",  "client_encoding",
                        "application_name", "options", nullptr};
  const char* values[] = {timeout.c_str(), o.url.c_str(),   "UTF8",
                          "kinemetricd",   options.c_str(), nullptr};
  c_ = PQconnectdbParams(keys, values, 1);
  if (!c_ || PQstatus(c_) != CONNECTION_OK) {
    std::string msg = c_ ? PQerrorMessage(c_) : "out of memory";
    msg = OneLine(msg);
    PQfinish(c_);
    c_ = nullptr;
    throw StorageError("storage: connect to " + MaskPassword(o.url) + ": " + msg,
                       SqlStateCode("08001"), true);
  }
  PQsetNoticeProcessor(
      c_, [](void*, const char*) {}, nullptr);
}

Conn::~Conn() {
  PQfinish(c_);
}

void Conn::Fail(const PGresult* r, const std::string& what) {
  Throw(c_, const_cast<PGresult*>(r), what);
}

void Conn::Exec(const std::string& sql, const std::string& what) {
  PGresult* r = PQexec(c_, sql.c_str());
  if (!r || !Ok(r)) Fail(r, what);
  PQclear(r);
}

Result Conn::Query(const std::string& sql, const Params& params, const std::string& what,
                   bool binary) {
  auto it = prepared_.find(sql);
  if (it == prepared_.end()) {
    const std::string name = "km" + std::to_string(prepared_.size() + 1);
    PGresult* p = PQprepare(c_, name.c_str(), sql.c_str(), 0, nullptr);
    if (!p || !Ok(p)) Fail(p, what);
    PQclear(p);
    it = prepared_.emplace(sql, name).first;
  }
  PGresult* r = PQexecPrepared(c_, it->second.c_str(), params.size(), params.values(),
                               params.lengths(), params.formats(), binary ? 1 : 0);
  if (!r || !Ok(r)) Fail(r, what);
  return Result(r);
}

std::optional<Result> Conn::TryQuery(const std::string& sql, const Params& params,
                                     const std::string& what) {
  try {
    return Query(sql, params, what);
  } catch (const StorageError& e) {
    if (e.code() / (36 * 36 * 36) == SqlStateCode("23")) return std::nullopt;
    throw;
  }
}

bool Conn::Healthy() {
  if (PQstatus(c_) != CONNECTION_OK || PQtransactionStatus(c_) != PQTRANS_IDLE) return false;
  // An idle connection is sent nothing (no LISTEN here): anything readable is the server
  // saying goodbye (a shutdown or restart terminates its sessions) or the connection's end.
  pollfd p{PQsocket(c_), POLLIN, 0};
  return ::poll(&p, 1, 0) == 0;
}

Lease::~Lease() {
  if (conn_) pool_->Return(std::move(conn_));
}

Pool::Pool(ConnOptions options, int size) : options_(std::move(options)), size_(size) {}

Lease Pool::Acquire() {
  std::unique_lock lock(mu_);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.busy_timeout_ms);
  for (;;) {
    while (!idle_.empty()) {
      auto conn = std::move(idle_.back());
      idle_.pop_back();
      if (conn->Healthy()) return Lease(*this, std::move(conn));
      --open_;  // the server closed it (a restart): a new one below
    }
    if (open_ < size_) {
      ++open_;
      lock.unlock();
      try {
        return Lease(*this, std::make_unique<Conn>(options_));
      } catch (...) {
        lock.lock();
        --open_;
        freed_.notify_one();
        throw;
      }
    }
    if (freed_.wait_until(lock, deadline) == std::cv_status::timeout && idle_.empty() &&
        open_ >= size_) {
      throw StorageError("storage: all " + std::to_string(size_) +
                             " database connections stayed in use for " +
                             std::to_string(options_.busy_timeout_ms) + " ms",
                         SqlStateCode("53300"), true);
    }
  }
}

void Pool::Fill() {
  for (;;) {
    {
      std::lock_guard lock(mu_);
      if (open_ >= size_) return;
      ++open_;
    }
    std::unique_ptr<Conn> conn;
    try {
      conn = std::make_unique<Conn>(options_);
    } catch (const std::exception&) {
      std::lock_guard lock(mu_);
      --open_;
      return;
    }
    Return(std::move(conn));
  }
}

void Pool::Return(std::unique_ptr<Conn> conn) {
  const bool keep =
      PQstatus(conn->raw()) == CONNECTION_OK && PQtransactionStatus(conn->raw()) == PQTRANS_IDLE;
  if (!keep) conn.reset();  // closed outside the lock
  std::lock_guard lock(mu_);
  if (keep) {
    idle_.push_back(std::move(conn));
  } else {
    --open_;
  }
  freed_.notify_one();
}

Transaction::~Transaction() {
  if (done_ || PQstatus(c_.raw()) != CONNECTION_OK) return;
  if (PGresult* r = PQexec(c_.raw(), "ROLLBACK")) PQclear(r);
}

}  // namespace km::server::pg
