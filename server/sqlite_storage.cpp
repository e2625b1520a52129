#include "server/sqlite_storage.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "analysis/core/errors.h"
#include "server/sqlite_db.h"
#include "server/time_util.h"

namespace km::server {
namespace {

using sqlite::Exec;
using sqlite::Stmt;
using sqlite::StorageError;
using sqlite::Transaction;

// Numbered migrations: migration i brings the schema from user_version i to i + 1.
const char* const kMigrations[] = {
    // 1: measurements, results, tokens.
    R"sql(
CREATE TABLE measurements (
  id            INTEGER PRIMARY KEY,
  sha256        TEXT NOT NULL UNIQUE,
  kind          TEXT NOT NULL,
  format        TEXT NOT NULL,
  machine_id    TEXT NOT NULL,
  test_id       TEXT NOT NULL DEFAULT '',
  direction     TEXT NOT NULL DEFAULT '',
  measured_at   TEXT,
  uploaded_at   TEXT NOT NULL,
  filename      TEXT NOT NULL DEFAULT '',
  sample_count  INTEGER NOT NULL,
  metadata_json TEXT NOT NULL,
  raw           BLOB NOT NULL,
  samples       BLOB NOT NULL
);
CREATE INDEX measurements_by_machine ON measurements(machine_id, kind);
CREATE INDEX measurements_by_time ON measurements(COALESCE(measured_at, uploaded_at));
CREATE TRIGGER measurements_immutable BEFORE UPDATE ON measurements
  BEGIN SELECT RAISE(ABORT, 'measurements are immutable'); END;
CREATE TRIGGER measurements_kept BEFORE DELETE ON measurements
  BEGIN SELECT RAISE(ABORT, 'measurements are never deleted'); END;
CREATE TABLE results (
  id               INTEGER PRIMARY KEY,
  measurement_id   INTEGER NOT NULL REFERENCES measurements(id),
  analysis         TEXT NOT NULL,
  analysis_version TEXT NOT NULL,
  input_sha256     TEXT NOT NULL,
  created_at       TEXT NOT NULL,
  result_json      TEXT NOT NULL,
  UNIQUE (measurement_id, analysis, analysis_version)
);
CREATE TABLE tokens (
  id           INTEGER PRIMARY KEY,
  token_sha256 TEXT NOT NULL UNIQUE,
  role         TEXT NOT NULL,
  label        TEXT NOT NULL DEFAULT '',
  created_at   TEXT NOT NULL
);
)sql",
    // 2: background jobs (calibration studies) and their stored results.
    R"sql(
CREATE TABLE jobs (
  id           INTEGER PRIMARY KEY,
  kind         TEXT NOT NULL,
  status       TEXT NOT NULL,
  progress     REAL NOT NULL DEFAULT 0,
  stage        TEXT NOT NULL DEFAULT '',
  request_json TEXT NOT NULL,
  result_json  TEXT NOT NULL DEFAULT '',
  error        TEXT NOT NULL DEFAULT '',
  created_at   TEXT NOT NULL,
  updated_at   TEXT NOT NULL
);
)sql",
    // 3: capacitance-sensor streams: chunks of consecutive samples, recorded gaps.
    R"sql(
CREATE TABLE streams (
  id            INTEGER PRIMARY KEY,
  machine_id    TEXT NOT NULL,
  name          TEXT NOT NULL DEFAULT '',
  source        TEXT NOT NULL,
  metadata_json TEXT NOT NULL,
  created_at    TEXT NOT NULL
);
CREATE INDEX streams_by_machine ON streams(machine_id);
CREATE TABLE stream_chunks (
  id            INTEGER PRIMARY KEY,
  stream_id     INTEGER NOT NULL REFERENCES streams(id),
  channel       INTEGER NOT NULL,
  first_counter INTEGER NOT NULL,
  n             INTEGER NOT NULL,
  t_first_us    INTEGER NOT NULL,
  t_last_us     INTEGER NOT NULL,
  value_min     REAL NOT NULL,
  value_max     REAL NOT NULL,
  value_sum     REAL NOT NULL,
  flagged       INTEGER NOT NULL,
  data          BLOB NOT NULL,
  UNIQUE (stream_id, channel, first_counter)
);
CREATE INDEX stream_chunks_by_time ON stream_chunks(stream_id, channel, t_first_us);
CREATE TRIGGER stream_chunks_immutable BEFORE UPDATE ON stream_chunks
  BEGIN SELECT RAISE(ABORT, 'stream samples are immutable'); END;
CREATE TRIGGER stream_chunks_kept BEFORE DELETE ON stream_chunks
  BEGIN SELECT RAISE(ABORT, 'stream samples are never deleted'); END;
CREATE TABLE stream_gaps (
  id            INTEGER PRIMARY KEY,
  stream_id     INTEGER NOT NULL REFERENCES streams(id),
  channel       INTEGER NOT NULL,
  first_missing INTEGER NOT NULL,
  missing       INTEGER NOT NULL,
  t_before_us   INTEGER NOT NULL,
  t_after_us    INTEGER NOT NULL,
  detected_at   TEXT NOT NULL
);
CREATE INDEX stream_gaps_by_stream ON stream_gaps(stream_id, channel);
)sql",
    // 4: machine definitions, versioned: a new version is appended, none is ever changed.
    R"sql(
CREATE TABLE machine_models (
  id         INTEGER PRIMARY KEY,
  machine_id TEXT NOT NULL,
  version    INTEGER NOT NULL CHECK (version >= 1),
  created_at TEXT NOT NULL,
  source     TEXT NOT NULL,
  note       TEXT NOT NULL DEFAULT '',
  document   BLOB NOT NULL,
  sha256     TEXT NOT NULL,
  UNIQUE (machine_id, version)
);
CREATE TRIGGER machine_models_immutable BEFORE UPDATE ON machine_models
  BEGIN SELECT RAISE(ABORT, 'machine model versions are immutable'); END;
CREATE TRIGGER machine_models_kept BEFORE DELETE ON machine_models
  BEGIN SELECT RAISE(ABORT, 'machine model versions are never deleted'); END;
)sql",
};

constexpr int kSchemaVersion = static_cast<int>(sizeof(kMigrations) / sizeof(kMigrations[0]));

// A database file on disk (not ":memory:", a temporary or a URI)?
bool IsFilePath(const std::string& path) {
  return !path.empty() && path != ":memory:" && path.rfind("file:", 0) != 0;
}

// The database holds measurements and token hashes: owner-only (0600) whatever the umask.
// The file is created here before SQLite opens it (SQLite gives its -wal, -shm and -journal
// files the mode of the database file); an existing one is tightened.
void MakeOwnerOnly(const std::string& path, bool create) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC | (create ? O_CREAT : 0), 0600);
  if (fd < 0) return;  // absent (-wal, -shm), or SQLite reports why it cannot open it
  const int rc = ::fchmod(fd, 0600);
  const int err = errno;
  ::close(fd);
  if (rc != 0) {
    throw StorageError("storage: cannot make " + path +
                       " owner-only (0600): " + std::strerror(err));
  }
}

MeasurementRecord ReadRecord(const Stmt& s) {
  MeasurementRecord r;
  r.id = s.Int(0);
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
  return kSchemaVersion;
}

SqliteStorage::SqliteStorage(const std::string& path) {
  const bool on_disk = IsFilePath(path);
  if (on_disk) MakeOwnerOnly(path, true);
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw StorageError("storage: cannot open " + path + ": " + msg);
  }
  try {
    sqlite3_busy_timeout(db_, 5000);
    Exec(db_, "PRAGMA journal_mode=WAL");
    Exec(db_, "PRAGMA synchronous=FULL");
    Exec(db_, "PRAGMA foreign_keys=ON");
    Migrate();
    if (on_disk) {
      for (const char* ext : {"-wal", "-shm", "-journal"}) MakeOwnerOnly(path + ext, false);
    }
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

SqliteStorage::~SqliteStorage() {
  if (db_) sqlite3_close(db_);
}

void SqliteStorage::Migrate() {
  int version = 0;
  {
    Stmt s(db_, "PRAGMA user_version");
    if (s.Step()) version = static_cast<int>(s.Int(0));
  }
  if (version > kSchemaVersion) {
    throw StorageError("storage: the database schema version " + std::to_string(version) +
                       " is newer than this program knows (" + std::to_string(kSchemaVersion) +
                       "); refusing to touch it");
  }
  for (int v = version; v < kSchemaVersion; ++v) {
    Transaction tx(db_);
    Exec(db_, kMigrations[v]);
    Exec(db_, ("PRAGMA user_version=" + std::to_string(v + 1)).c_str());
    tx.Commit();
  }
}

void SqliteStorage::InsertResult(std::int64_t id, const std::string& sha, const NewResult& r) {
  Stmt s(db_,
         "INSERT INTO results (measurement_id, analysis, analysis_version, input_sha256, "
         "created_at, result_json) VALUES (?, ?, ?, ?, ?, ?) "
         "ON CONFLICT (measurement_id, analysis, analysis_version) DO NOTHING");
  s.Bind(1, id).Bind(2, r.analysis).Bind(3, r.analysis_version).Bind(4, sha);
  s.Bind(5, NowUtcIso8601()).Bind(6, r.result_json);
  s.Step();
}

PutOutcome SqliteStorage::PutMeasurement(const NewMeasurement& m,
                                         const std::vector<NewResult>& results) {
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  {
    Stmt find(db_, "SELECT id FROM measurements WHERE sha256 = ?");
    find.Bind(1, m.sha256);
    if (find.Step()) return PutOutcome{find.Int(0), false};
  }
  Stmt s(db_,
         "INSERT INTO measurements (sha256, kind, format, machine_id, test_id, direction, "
         "measured_at, uploaded_at, filename, sample_count, metadata_json, raw, samples) "
         "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  s.Bind(1, m.sha256).Bind(2, m.kind).Bind(3, m.format).Bind(4, m.machine_id);
  s.Bind(5, m.test_id).Bind(6, m.direction).Bind(7, m.measured_at).Bind(8, NowUtcIso8601());
  s.Bind(9, m.filename).Bind(10, static_cast<std::int64_t>(m.samples.rows()));
  s.Bind(11, m.metadata_json).BindBlob(12, m.raw).BindBlob(13, EncodeSamples(m.samples));
  s.Step();
  const std::int64_t id = sqlite3_last_insert_rowid(db_);
  for (const auto& r : results) InsertResult(id, m.sha256, r);
  tx.Commit();
  return PutOutcome{id, true};
}

std::optional<MeasurementRecord> SqliteStorage::GetMeasurement(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         (std::string("SELECT ") + kRecordColumns + " FROM measurements WHERE id = ?").c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadRecord(s);
}

std::optional<std::int64_t> SqliteStorage::FindBySha256(const std::string& sha256) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT id FROM measurements WHERE sha256 = ?");
  s.Bind(1, sha256);
  if (!s.Step()) return std::nullopt;
  return s.Int(0);
}

std::string SqliteStorage::GetRaw(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT raw FROM measurements WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  return s.Blob(0);
}

SampleBlock SqliteStorage::GetSamples(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT samples FROM measurements WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  return DecodeSamples(s.Blob(0));
}

MeasurementPage SqliteStorage::ListMeasurements(const MeasurementFilter& f) {
  std::lock_guard lock(mu_);
  std::string where = " WHERE 1=1";
  if (f.machine_id) where += " AND machine_id = :machine";
  if (f.kind) where += " AND kind = :kind";
  if (f.test_id) where += " AND test_id = :test";
  if (f.from) where += " AND COALESCE(measured_at, uploaded_at) >= :from";
  if (f.to) where += " AND COALESCE(measured_at, uploaded_at) < :to";
  auto bind = [&](Stmt& s, sqlite3* db) {
    (void)db;
    int i = 1;
    if (f.machine_id) s.Bind(i++, *f.machine_id);
    if (f.kind) s.Bind(i++, *f.kind);
    if (f.test_id) s.Bind(i++, *f.test_id);
    if (f.from) s.Bind(i++, *f.from);
    if (f.to) s.Bind(i++, *f.to);
    return i;
  };
  MeasurementPage page;
  {
    Stmt c(db_, ("SELECT COUNT(*) FROM measurements" + where).c_str());
    bind(c, db_);
    if (c.Step()) page.total = c.Int(0);
  }
  Stmt s(db_, (std::string("SELECT ") + kRecordColumns + " FROM measurements" + where +
               " ORDER BY COALESCE(measured_at, uploaded_at), id LIMIT ? OFFSET ?")
                  .c_str());
  const int next = bind(s, db_);
  s.Bind(next, f.limit).Bind(next + 1, f.offset);
  while (s.Step()) page.items.push_back(ReadRecord(s));
  return page;
}

std::vector<ResultRecord> SqliteStorage::GetResults(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "SELECT measurement_id, analysis, analysis_version, input_sha256, created_at, "
         "result_json FROM results WHERE measurement_id = ? ORDER BY id");
  s.Bind(1, id);
  std::vector<ResultRecord> out;
  while (s.Step()) {
    out.push_back(ResultRecord{s.Int(0), s.Text(1), s.Text(2), s.Text(3), s.Text(4), s.Text(5)});
  }
  return out;
}

void SqliteStorage::PutResult(std::int64_t id, const NewResult& r) {
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  Stmt s(db_, "SELECT sha256 FROM measurements WHERE id = ?");
  s.Bind(1, id);
  if (!s.Step()) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  InsertResult(id, s.Text(0), r);
  tx.Commit();
}

std::vector<MachineSummary> SqliteStorage::ListMachines() {
  std::lock_guard lock(mu_);
  // Machines with measurements, with a stored model, or both.
  Stmt s(db_,
         "SELECT machine_id, SUM(n), MAX(t), SUM(v) FROM ("
         " SELECT machine_id, COUNT(*) AS n, MAX(COALESCE(measured_at, uploaded_at)) AS t,"
         " 0 AS v FROM measurements GROUP BY machine_id"
         " UNION ALL"
         " SELECT machine_id, 0, NULL, MAX(version) FROM machine_models GROUP BY machine_id"
         ") GROUP BY machine_id ORDER BY machine_id");
  std::vector<MachineSummary> out;
  while (s.Step()) out.push_back(MachineSummary{s.Text(0), s.Int(1), s.OptText(2), s.Int(3)});
  return out;
}

namespace {
constexpr const char* kJobColumns =
    "id, kind, status, progress, stage, request_json, result_json, error, created_at, updated_at";
JobRecord ReadJob(const Stmt& s) {
  JobRecord j;
  j.id = s.Int(0);
  j.kind = s.Text(1);
  j.status = s.Text(2);
  j.progress = s.Real(3);
  j.stage = s.Text(4);
  j.request_json = s.Text(5);
  j.result_json = s.Text(6);
  j.error = s.Text(7);
  j.created_at = s.Text(8);
  j.updated_at = s.Text(9);
  return j;
}
}  // namespace

std::int64_t SqliteStorage::CreateJob(const std::string& kind, const std::string& request_json) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "INSERT INTO jobs (kind, status, request_json, created_at, updated_at) "
         "VALUES (?, 'queued', ?, ?, ?)");
  const std::string now = NowUtcIso8601();
  s.Bind(1, kind).Bind(2, request_json).Bind(3, now).Bind(4, now);
  s.Step();
  return sqlite3_last_insert_rowid(db_);
}

void SqliteStorage::UpdateJob(const JobRecord& job) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "UPDATE jobs SET status = ?, progress = ?, stage = ?, result_json = ?, error = ?, "
         "updated_at = ? WHERE id = ?");
  s.Bind(1, job.status).BindReal(2, job.progress).Bind(3, job.stage).Bind(4, job.result_json);
  s.Bind(5, job.error).Bind(6, NowUtcIso8601()).Bind(7, job.id);
  s.Step();
}

std::optional<JobRecord> SqliteStorage::GetJob(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, (std::string("SELECT ") + kJobColumns + " FROM jobs WHERE id = ?").c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadJob(s);
}

std::vector<JobRecord> SqliteStorage::ListJobs(std::int64_t limit) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         (std::string("SELECT ") + kJobColumns + " FROM jobs ORDER BY id DESC LIMIT ?").c_str());
  s.Bind(1, limit);
  std::vector<JobRecord> out;
  while (s.Step()) out.push_back(ReadJob(s));
  return out;
}

int SqliteStorage::FailInterruptedJobs(const std::string& reason) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "UPDATE jobs SET status = 'failed', error = ?, updated_at = ? "
         "WHERE status IN ('queued', 'running')");
  s.Bind(1, reason).Bind(2, NowUtcIso8601());
  s.Step();
  return sqlite3_changes(db_);
}

namespace {
StreamRecord ReadStream(const Stmt& s) {
  return StreamRecord{s.Int(0), s.Text(1), s.Text(2), s.Text(3), s.Text(4), s.Text(5)};
}
constexpr const char* kStreamColumns = "id, machine_id, name, source, metadata_json, created_at";
}  // namespace

std::int64_t SqliteStorage::CreateStream(const NewStream& st) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "INSERT INTO streams (machine_id, name, source, metadata_json, created_at) "
         "VALUES (?, ?, ?, ?, ?)");
  s.Bind(1, st.machine_id).Bind(2, st.name).Bind(3, st.source).Bind(4, st.metadata_json);
  s.Bind(5, NowUtcIso8601());
  s.Step();
  return sqlite3_last_insert_rowid(db_);
}

std::optional<StreamRecord> SqliteStorage::GetStream(std::int64_t id) {
  std::lock_guard lock(mu_);
  Stmt s(db_, (std::string("SELECT ") + kStreamColumns + " FROM streams WHERE id = ?").c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadStream(s);
}

std::vector<StreamRecord> SqliteStorage::ListStreams(const std::optional<std::string>& machine_id,
                                                     std::int64_t limit) {
  std::lock_guard lock(mu_);
  Stmt s(db_, (std::string("SELECT ") + kStreamColumns +
               " FROM streams WHERE (?1 IS NULL OR machine_id = ?1) ORDER BY id DESC LIMIT ?2")
                  .c_str());
  s.Bind(1, machine_id).Bind(2, limit);
  std::vector<StreamRecord> out;
  while (s.Step()) out.push_back(ReadStream(s));
  return out;
}

void SqliteStorage::AppendStream(const std::vector<StreamChunk>& chunks,
                                 const std::vector<StreamGap>& gaps) {
  if (chunks.empty() && gaps.empty()) return;
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  if (!chunks.empty()) {
    Stmt s(db_,
           "INSERT INTO stream_chunks (stream_id, channel, first_counter, n, t_first_us, "
           "t_last_us, value_min, value_max, value_sum, flagged, data) "
           "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    for (const auto& c : chunks) {
      s.Reset();
      s.Bind(1, c.stream_id).Bind(2, c.channel).Bind(3, c.first_counter).Bind(4, c.n);
      s.Bind(5, c.t_first_us).Bind(6, c.t_last_us).BindReal(7, c.value_min);
      s.BindReal(8, c.value_max).BindReal(9, c.value_sum).Bind(10, c.flagged);
      s.BindBlob(11, c.data);
      if (!s.TryStep()) {
        throw InvalidInput("", 0, "counter",
                           "channel " + std::to_string(c.channel) + " counter " +
                               std::to_string(c.first_counter) + " of stream " +
                               std::to_string(c.stream_id) + " is stored already");
      }
    }
  }
  if (!gaps.empty()) {
    Stmt s(db_,
           "INSERT INTO stream_gaps (stream_id, channel, first_missing, missing, t_before_us, "
           "t_after_us, detected_at) VALUES (?, ?, ?, ?, ?, ?, ?)");
    const std::string now = NowUtcIso8601();
    for (const auto& g : gaps) {
      s.Reset();
      s.Bind(1, g.stream_id).Bind(2, g.channel).Bind(3, g.first_missing).Bind(4, g.missing);
      s.Bind(5, g.t_before_us)
          .Bind(6, g.t_after_us)
          .Bind(7, g.detected_at.empty() ? now : g.detected_at);
      s.Step();
    }
  }
  tx.Commit();
}

std::vector<StreamChannelSummary> SqliteStorage::StreamChannels(std::int64_t stream_id) {
  std::lock_guard lock(mu_);
  std::vector<StreamChannelSummary> out;
  {
    Stmt s(db_,
           "SELECT channel, SUM(n), COUNT(*), SUM(flagged), MIN(t_first_us), MAX(t_last_us), "
           "MAX(first_counter + n) FROM stream_chunks WHERE stream_id = ? GROUP BY channel "
           "ORDER BY channel");
    s.Bind(1, stream_id);
    while (s.Step()) {
      StreamChannelSummary c;
      c.channel = s.Int(0);
      c.samples = s.Int(1);
      c.chunks = s.Int(2);
      c.flagged = s.Int(3);
      c.first_t_us = s.Int(4);
      c.last_t_us = s.Int(5);
      c.next_counter = s.Int(6);
      out.push_back(c);
    }
  }
  Stmt g(db_,
         "SELECT channel, COUNT(*), SUM(missing) FROM stream_gaps WHERE stream_id = ? "
         "GROUP BY channel");
  g.Bind(1, stream_id);
  while (g.Step()) {
    for (auto& c : out) {
      if (c.channel == g.Int(0)) {
        c.gaps = g.Int(1);
        c.missing = g.Int(2);
      }
    }
  }
  return out;
}

std::vector<StreamChunk> SqliteStorage::ReadStreamChunks(std::int64_t stream_id,
                                                         std::int64_t channel, std::int64_t from_us,
                                                         std::int64_t to_us, bool with_data) {
  std::lock_guard lock(mu_);
  Stmt s(db_, with_data
                  ? "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                    "value_max, value_sum, flagged, data FROM stream_chunks WHERE stream_id = ? "
                    "AND channel = ? AND t_last_us >= ? AND t_first_us < ? ORDER BY first_counter"
                  : "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                    "value_max, value_sum, flagged FROM stream_chunks WHERE stream_id = ? "
                    "AND channel = ? AND t_last_us >= ? AND t_first_us < ? ORDER BY first_counter");
  s.Bind(1, stream_id).Bind(2, channel).Bind(3, from_us).Bind(4, to_us);
  std::vector<StreamChunk> out;
  while (s.Step()) {
    StreamChunk c;
    c.stream_id = stream_id;
    c.channel = s.Int(0);
    c.first_counter = s.Int(1);
    c.n = s.Int(2);
    c.t_first_us = s.Int(3);
    c.t_last_us = s.Int(4);
    c.value_min = s.Real(5);
    c.value_max = s.Real(6);
    c.value_sum = s.Real(7);
    c.flagged = s.Int(8);
    if (with_data) c.data = s.Blob(9);
    out.push_back(std::move(c));
  }
  return out;
}

std::string SqliteStorage::ReadStreamChunkData(std::int64_t stream_id, std::int64_t channel,
                                               std::int64_t first_counter) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "SELECT data FROM stream_chunks WHERE stream_id = ? AND channel = ? AND "
         "first_counter = ?");
  s.Bind(1, stream_id).Bind(2, channel).Bind(3, first_counter);
  if (!s.Step()) throw NotFound("no stream chunk at that counter");
  return s.Blob(0);
}

std::vector<StreamGap> SqliteStorage::StreamGaps(std::int64_t stream_id, std::int64_t limit) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "SELECT channel, first_missing, missing, t_before_us, t_after_us, detected_at "
         "FROM stream_gaps WHERE stream_id = ? ORDER BY t_before_us, channel LIMIT ?");
  s.Bind(1, stream_id).Bind(2, limit);
  std::vector<StreamGap> out;
  while (s.Step()) {
    out.push_back(
        StreamGap{stream_id, s.Int(0), s.Int(1), s.Int(2), s.Int(3), s.Int(4), s.Text(5)});
  }
  return out;
}

std::int64_t SqliteStorage::CountTokens() {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT COUNT(*) FROM tokens");
  return s.Step() ? s.Int(0) : 0;
}

void SqliteStorage::PutToken(const std::string& token_sha256, const std::string& role,
                             const std::string& label) {
  std::lock_guard lock(mu_);
  Stmt s(db_,
         "INSERT INTO tokens (token_sha256, role, label, created_at) VALUES (?, ?, ?, ?) "
         "ON CONFLICT (token_sha256) DO NOTHING");
  s.Bind(1, token_sha256).Bind(2, role).Bind(3, label).Bind(4, NowUtcIso8601());
  s.Step();
}

std::optional<std::string> SqliteStorage::FindTokenRole(const std::string& token_sha256) {
  std::lock_guard lock(mu_);
  Stmt s(db_, "SELECT role FROM tokens WHERE token_sha256 = ?");
  s.Bind(1, token_sha256);
  if (!s.Step()) return std::nullopt;
  return s.Text(0);
}

}  // namespace km::server
