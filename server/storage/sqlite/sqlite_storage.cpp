#include "server/storage/sqlite/sqlite_storage.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "analysis/core/errors.h"
#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_migrations.h"

namespace km::server {
namespace {

using sqlite::CachedStatement;
using sqlite::Exec;
using sqlite::Statement;
using sqlite::Transaction;

// A database file on disk (not ":memory:", a temporary or a URI)?
bool IsFilePath(const std::string& path) {
  return !path.empty() && path != ":memory:" && path.rfind("file:", 0) != 0;
}

// The database holds measurements and token hashes: owner-only (0600) whatever the umask.
// The file is created here before SQLite opens it (SQLite gives its -wal, -shm and -journal
// files the mode of the database file); an existing one is tightened. The -wal and -shm files
// of an open database are tightened by name, never opened: closing a descriptor of a file
// releases every POSIX lock this process holds on it, SQLite's included, and without its lock on
// the -shm file another process opening the database (a backup, the sqlite3 shell) takes itself
// for the first and truncates the shared memory the server has mapped (the server then dies of
// SIGBUS).
void MakeOwnerOnly(const std::string& path, bool create) {
  int rc = 0;
  if (create) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC | O_CREAT, 0600);
    if (fd < 0) return;  // SQLite reports why it cannot open it
    rc = ::fchmod(fd, 0600);
    const int err = errno;
    ::close(fd);
    errno = err;
  } else {
    rc = ::chmod(path.c_str(), 0600);
    if (rc != 0 && errno == ENOENT) return;  // absent (-wal, -shm, -journal)
  }
  const int err = errno;
  if (rc != 0) {
    throw StorageError("storage: cannot make " + path + " owner-only (0600): " + std::strerror(err),
                       SQLITE_CANTOPEN, false);
  }
}

MeasurementRecord ReadRecord(const Statement& s) {
  MeasurementRecord r;
  r.id = MeasurementId(s.Int(0));
  r.sha256 = s.Text(1);
  r.kind = s.Text(2);
  r.format = s.Text(3);
  r.machine_id = s.Text(4);
  r.test_id = s.Text(5);
  r.direction = s.Text(6);
  r.measured_at = s.OptText(7);
  r.uploaded_at = s.Text(8);
  r.filename = s.Text(9);
  r.sample_count = s.Int(10);
  r.metadata_json = s.Text(11);
  return r;
}

constexpr const char* kRecordColumns =
    "id, sha256, kind, format, machine_id, test_id, direction, measured_at, uploaded_at, "
    "filename, sample_count, metadata_json";

}  // namespace

int SqliteStorage::SchemaVersion() {
  return sqlite::SchemaVersion();
}

SqliteStorage::SqliteStorage(const std::string& path, SqliteOptions options) {
  const bool on_disk = IsFilePath(path);
  if (on_disk) MakeOwnerOnly(path, true);
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    const int code = db_ ? sqlite3_errcode(db_) : SQLITE_NOMEM;
    std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw StorageError("storage: cannot open " + path + ": " + msg, code & 0xff, false);
  }
  try {
    sqlite3_busy_timeout(db_, options.busy_timeout_ms);
    Exec(db_, "PRAGMA journal_mode=WAL");
    Exec(db_, "PRAGMA synchronous=FULL");
    Exec(db_, "PRAGMA foreign_keys=ON");
    sqlite::Migrate(db_);
    if (on_disk) {
      for (const char* ext : {"-wal", "-shm", "-journal"}) MakeOwnerOnly(path + ext, false);
    }
    statements_ = std::make_unique<sqlite::StatementCache>(db_);
  } catch (...) {
    Close();
    throw;
  }
}

SqliteStorage::~SqliteStorage() {
  Close();
}

void SqliteStorage::Close() {
  statements_.reset();  // every statement finalised before the connection closes
  if (db_) sqlite3_close(db_);
  db_ = nullptr;
}

CachedStatement SqliteStorage::Prepared(const std::string& sql) {
  return CachedStatement(*statements_, sql);
}

void SqliteStorage::InsertResult(MeasurementId id, const std::string& sha, const NewResult& r) {
  auto s = Prepared(
      "INSERT INTO results (measurement_id, analysis, analysis_version, input_sha256, "
      "created_at, result_json) VALUES (?, ?, ?, ?, ?, ?) "
      "ON CONFLICT (measurement_id, analysis, analysis_version) DO NOTHING");
  s->Bind(1, id).Bind(2, r.analysis).Bind(3, r.analysis_version).Bind(4, sha);
  s->Bind(5, NowUtcIso8601()).Bind(6, r.result_json);
  s->Step();
}

PutOutcome SqliteStorage::PutMeasurement(const NewMeasurement& m,
                                         const std::vector<NewResult>& results) {
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  {
    auto find = Prepared("SELECT id FROM measurements WHERE sha256 = ?");
    find->Bind(1, m.sha256);
    if (find->Step()) return PutOutcome{MeasurementId(find->Int(0)), false};
  }
  auto s = Prepared(
      "INSERT INTO measurements (sha256, kind, format, machine_id, test_id, direction, "
      "measured_at, uploaded_at, filename, sample_count, metadata_json, raw, samples) "
      "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  s->Bind(1, m.sha256).Bind(2, m.kind).Bind(3, m.format).Bind(4, m.machine_id);
  s->Bind(5, m.test_id).Bind(6, m.direction).Bind(7, m.measured_at).Bind(8, NowUtcIso8601());
  s->Bind(9, m.filename).Bind(10, static_cast<std::int64_t>(m.samples.rows()));
  s->Bind(11, m.metadata_json).BindBlob(12, m.raw).BindBlob(13, EncodeSamples(m.samples));
  s->Step();
  const MeasurementId id(sqlite3_last_insert_rowid(db_));
  for (const auto& r : results) InsertResult(id, m.sha256, r);
  tx.Commit();
  return PutOutcome{id, true};
}

std::optional<MeasurementRecord> SqliteStorage::GetMeasurement(MeasurementId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kRecordColumns + " FROM measurements WHERE id = ?"));
  s->Bind(1, id);
  if (!s->Step()) return std::nullopt;
  return ReadRecord(*s);
}

std::optional<MeasurementId> SqliteStorage::FindBySha256(const std::string& sha256) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT id FROM measurements WHERE sha256 = ?");
  s->Bind(1, sha256);
  if (!s->Step()) return std::nullopt;
  return MeasurementId(s->Int(0));
}

std::string SqliteStorage::GetRaw(MeasurementId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT raw FROM measurements WHERE id = ?");
  s->Bind(1, id);
  if (!s->Step()) throw NotFound("measurement " + to_string(id) + " does not exist");
  return s->Blob(0);
}

SampleBlock SqliteStorage::GetSamples(MeasurementId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT samples FROM measurements WHERE id = ?");
  s->Bind(1, id);
  if (!s->Step()) throw NotFound("measurement " + to_string(id) + " does not exist");
  return DecodeSamples(s->Blob(0));
}

MeasurementPage SqliteStorage::ListMeasurements(const MeasurementFilter& f) {
  std::lock_guard lock(mu_);
  // Free text: a substring of name, test, direction or kind (LIKE: ASCII letters in either
  // case); or an id.
  std::optional<std::string> text;  // a LIKE pattern: %text% with % _ \ escaped
  std::optional<std::int64_t> text_id;
  if (f.text && !f.text->empty()) {
    text = "%";
    for (const char c : *f.text) {
      if (c == '%' || c == '_' || c == '\\') *text += '\\';
      *text += c;
    }
    *text += '%';
    const std::string digits = (*f.text)[0] == '#' ? f.text->substr(1) : *f.text;
    if (!digits.empty() && digits.size() <= 15 &&
        digits.find_first_not_of("0123456789") == std::string::npos) {
      text_id = std::stoll(digits);
    }
  }
  std::string where = " WHERE 1=1";
  if (f.machine_id) where += " AND machine_id = ?";
  if (f.kind) where += " AND kind = ?";
  if (f.test_id) where += " AND test_id = ?";
  if (f.direction) where += " AND direction = ?";
  if (f.from) where += " AND COALESCE(measured_at, uploaded_at) >= ?";
  if (f.to) where += " AND COALESCE(measured_at, uploaded_at) < ?";
  if (text) {
    const std::string match =
        "(filename LIKE ? ESCAPE '\\' OR test_id LIKE ? ESCAPE '\\'"
        " OR direction LIKE ? ESCAPE '\\' OR kind LIKE ? ESCAPE '\\')";
    // Within a machine the text is matched on the entries of an index holding these columns
    // (tens of bytes each), not on the rows, which carry the raw file and the samples.
    where += f.machine_id ? " AND (id IN (SELECT id FROM measurements INDEXED BY "
                            "measurements_by_machine_text WHERE machine_id = ? AND " +
                                match + ")"
                          : " AND (" + match;
    where += text_id ? " OR id = ?)" : ")";
  }
  auto bind = [&](Statement& s) {
    int i = 1;
    if (f.machine_id) s.Bind(i++, *f.machine_id);
    if (f.kind) s.Bind(i++, *f.kind);
    if (f.test_id) s.Bind(i++, *f.test_id);
    if (f.direction) s.Bind(i++, *f.direction);
    if (f.from) s.Bind(i++, *f.from);
    if (f.to) s.Bind(i++, *f.to);
    if (text) {
      if (f.machine_id) s.Bind(i++, *f.machine_id);
      for (int k = 0; k < 4; ++k) s.Bind(i++, *text);
      if (text_id) s.Bind(i++, *text_id);
    }
    return i;
  };
  const char* order = " ORDER BY COALESCE(measured_at, uploaded_at), id";
  if (f.order == MeasurementFilter::Order::kNewest) {
    order = " ORDER BY COALESCE(measured_at, uploaded_at) DESC, id DESC";
  } else if (f.order == MeasurementFilter::Order::kUploaded) {
    order = " ORDER BY id DESC";
  }
  MeasurementPage page;
  {
    auto s = Prepared((std::string("SELECT ") + kRecordColumns + " FROM measurements" + where +
                       order + " LIMIT ? OFFSET ?"));
    const int next = bind(*s);
    s->Bind(next, f.limit).Bind(next + 1, f.offset);
    while (s->Step()) page.items.push_back(ReadRecord(*s));
  }
  // A first page that is not full holds every match: no second pass to count them.
  if (f.offset == 0 && static_cast<std::int64_t>(page.items.size()) < f.limit) {
    page.total = static_cast<std::int64_t>(page.items.size());
    return page;
  }
  auto c = Prepared(("SELECT COUNT(*) FROM measurements" + where));
  bind(*c);
  if (c->Step()) page.total = c->Int(0);
  return page;
}

std::vector<ResultRecord> SqliteStorage::GetResults(MeasurementId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "SELECT measurement_id, analysis, analysis_version, input_sha256, created_at, "
      "result_json FROM results WHERE measurement_id = ? ORDER BY id");
  s->Bind(1, id);
  std::vector<ResultRecord> out;
  while (s->Step()) {
    out.push_back(ResultRecord{MeasurementId(s->Int(0)), s->Text(1), s->Text(2), s->Text(3),
                               s->Text(4), s->Text(5)});
  }
  return out;
}

AnswerBasis SqliteStorage::GetAnswerBasis(MeasurementId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "SELECT count(*), COALESCE(max(id), 0), COALESCE((SELECT max(version) FROM "
      "tolerance_tables WHERE machine_id = (SELECT machine_id FROM measurements WHERE id = ?1)), "
      "0) FROM results WHERE measurement_id = ?1");
  s->Bind(1, id);
  s->Step();
  return AnswerBasis{{s->Int(0), s->Int(1)}, s->Int(2)};
}

void SqliteStorage::PutResult(MeasurementId id, const NewResult& r) {
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  auto s = Prepared("SELECT sha256 FROM measurements WHERE id = ?");
  s->Bind(1, id);
  if (!s->Step()) throw NotFound("measurement " + to_string(id) + " does not exist");
  InsertResult(id, s->Text(0), r);
  tx.Commit();
}

std::vector<MachineSummary> SqliteStorage::ListMachines() {
  std::lock_guard lock(mu_);
  // Machines with measurements, with a stored model, or both.
  auto s = Prepared(
      "SELECT machine_id, SUM(n), MAX(t), SUM(v) FROM ("
      " SELECT machine_id, COUNT(*) AS n, MAX(COALESCE(measured_at, uploaded_at)) AS t,"
      " 0 AS v FROM measurements GROUP BY machine_id"
      " UNION ALL"
      " SELECT machine_id, 0, NULL, MAX(version) FROM machine_models GROUP BY machine_id"
      ") GROUP BY machine_id ORDER BY machine_id");
  std::vector<MachineSummary> out;
  while (s->Step()) out.push_back(MachineSummary{s->Text(0), s->Int(1), s->OptText(2), s->Int(3)});
  return out;
}

std::int64_t SqliteStorage::CountTokens() {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT COUNT(*) FROM tokens");
  return s->Step() ? s->Int(0) : 0;
}

void SqliteStorage::PutToken(const std::string& token_sha256, const std::string& role,
                             const std::string& label) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO tokens (token_sha256, role, label, created_at) VALUES (?, ?, ?, ?) "
      "ON CONFLICT (token_sha256) DO NOTHING");
  s->Bind(1, token_sha256).Bind(2, role).Bind(3, label).Bind(4, NowUtcIso8601());
  s->Step();
}

std::optional<std::string> SqliteStorage::FindTokenRole(const std::string& token_sha256) {
  std::lock_guard lock(mu_);
  auto s = Prepared("SELECT role FROM tokens WHERE token_sha256 = ?");
  s->Bind(1, token_sha256);
  if (!s->Step()) return std::nullopt;
  return s->Text(0);
}

}  // namespace km::server
