#include "server/storage/sqlite/sqlite_migrations.h"

#include <string>

#include "server/storage/sqlite/sqlite_db.h"

namespace km::server::sqlite {
namespace {

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
    // 5: measurement lists of a machine paged in time or upload order, a test's files, and the
    // free-text search of a machine's list (on the small entries of an index, not on the rows),
    // answered from indexes however many measurements a machine has.
    R"sql(
CREATE INDEX measurements_by_machine_time
  ON measurements(machine_id, COALESCE(measured_at, uploaded_at), id);
CREATE INDEX measurements_by_machine_kind_time
  ON measurements(machine_id, kind, COALESCE(measured_at, uploaded_at), id);
CREATE INDEX measurements_by_machine_upload ON measurements(machine_id, id);
CREATE INDEX measurements_by_test ON measurements(machine_id, test_id, kind);
CREATE INDEX measurements_by_machine_text
  ON measurements(machine_id, filename, test_id, direction, kind);
)sql",
    // 6: named tokens with expiry and revocation; the audit log of state-changing requests,
    // appended only.
    R"sql(
ALTER TABLE tokens ADD COLUMN expires_at TEXT;
ALTER TABLE tokens ADD COLUMN revoked_at TEXT;
CREATE TABLE audit_log (
  id         INTEGER PRIMARY KEY,
  at         TEXT NOT NULL,
  token_id   INTEGER,
  token_name TEXT NOT NULL DEFAULT '',
  role       TEXT NOT NULL DEFAULT '',
  method     TEXT NOT NULL,
  path       TEXT NOT NULL,
  status     INTEGER NOT NULL,
  subject    TEXT NOT NULL DEFAULT ''
);
CREATE TRIGGER audit_log_immutable BEFORE UPDATE ON audit_log
  BEGIN SELECT RAISE(ABORT, 'audit entries are immutable'); END;
CREATE TRIGGER audit_log_kept BEFORE DELETE ON audit_log
  BEGIN SELECT RAISE(ABORT, 'audit entries are never deleted'); END;
)sql",
    // 7: accuracy audits: per machine the rules and the schedule (one row a machine, replaced
    // when changed), and the verdicts of every run, kept.
    R"sql(
CREATE TABLE audit_configs (
  machine_id  TEXT PRIMARY KEY,
  schedule    TEXT,
  rules_json  TEXT NOT NULL,
  updated_at  TEXT NOT NULL,
  last_run_at TEXT,
  next_run_at TEXT
);
CREATE INDEX audit_configs_due ON audit_configs(next_run_at);
CREATE TABLE audit_verdicts (
  id               INTEGER PRIMARY KEY,
  machine_id       TEXT NOT NULL,
  level            INTEGER NOT NULL CHECK (level BETWEEN 1 AND 3),
  run_trigger      TEXT NOT NULL,
  created_at       TEXT NOT NULL,
  verdict_json     TEXT NOT NULL,
  webhook_status   TEXT NOT NULL DEFAULT '',
  webhook_attempts INTEGER NOT NULL DEFAULT 0
);
CREATE INDEX audit_verdicts_by_machine ON audit_verdicts(machine_id, created_at, id);
CREATE INDEX audit_verdicts_by_time ON audit_verdicts(created_at, id);
CREATE TRIGGER audit_verdicts_kept BEFORE DELETE ON audit_verdicts
  BEGIN SELECT RAISE(ABORT, 'audit verdicts are never deleted'); END;
)sql",
    // 8: the job queue shared by every instance on the database: what a worker runs (the plan),
    // the instance running a job and until when its lease holds, and how often it was started.
    R"sql(
ALTER TABLE jobs ADD COLUMN plan_json TEXT NOT NULL DEFAULT '';
ALTER TABLE jobs ADD COLUMN lease_owner TEXT NOT NULL DEFAULT '';
ALTER TABLE jobs ADD COLUMN lease_until_ms INTEGER NOT NULL DEFAULT 0;
ALTER TABLE jobs ADD COLUMN attempts INTEGER NOT NULL DEFAULT 0;
CREATE INDEX jobs_by_status ON jobs(status, id);
)sql",
    // 9: the access token that submitted a job (its owner may cancel it; 0: not known).
    R"sql(
ALTER TABLE jobs ADD COLUMN owner_token_id INTEGER NOT NULL DEFAULT 0;
)sql",
    // 10: when each token was last used (to within a minute; GET /api/v1/tokens).
    R"sql(
ALTER TABLE tokens ADD COLUMN last_used_at TEXT;
)sql",
    // 11: tolerance tables, versioned per machine: a new version is appended, none is ever
    // changed.
    R"sql(
CREATE TABLE tolerance_tables (
  id              INTEGER PRIMARY KEY,
  machine_id      TEXT NOT NULL,
  version         INTEGER NOT NULL CHECK (version >= 1),
  created_at      TEXT NOT NULL,
  tolerances_json TEXT NOT NULL,
  sha256          TEXT NOT NULL,
  UNIQUE (machine_id, version)
);
CREATE TRIGGER tolerance_tables_immutable BEFORE UPDATE ON tolerance_tables
  BEGIN SELECT RAISE(ABORT, 'tolerance table versions are immutable'); END;
CREATE TRIGGER tolerance_tables_kept BEFORE DELETE ON tolerance_tables
  BEGIN SELECT RAISE(ABORT, 'tolerance table versions are never deleted'); END;
)sql",
    // 12: the instrument register, versioned per serial: a new version is appended, none is
    // ever changed.
    R"sql(
CREATE TABLE instruments (
  id              INTEGER PRIMARY KEY,
  serial          TEXT NOT NULL,
  version         INTEGER NOT NULL CHECK (version >= 1),
  created_at      TEXT NOT NULL,
  instrument_json TEXT NOT NULL,
  sha256          TEXT NOT NULL,
  UNIQUE (serial, version)
);
CREATE TRIGGER instruments_immutable BEFORE UPDATE ON instruments
  BEGIN SELECT RAISE(ABORT, 'instrument versions are immutable'); END;
CREATE TRIGGER instruments_kept BEFORE DELETE ON instruments
  BEGIN SELECT RAISE(ABORT, 'instrument versions are never deleted'); END;
)sql",
    // 13: the revisions of signed reports and their approvals: appended, never changed.
    R"sql(
CREATE TABLE report_revisions (
  id             INTEGER PRIMARY KEY,
  subject        TEXT NOT NULL,
  revision       INTEGER NOT NULL CHECK (revision >= 1),
  created_at     TEXT NOT NULL,
  content_sha256 TEXT NOT NULL,
  summary_json   TEXT NOT NULL,
  UNIQUE (subject, revision)
);
CREATE TRIGGER report_revisions_immutable BEFORE UPDATE ON report_revisions
  BEGIN SELECT RAISE(ABORT, 'report revisions are immutable'); END;
CREATE TRIGGER report_revisions_kept BEFORE DELETE ON report_revisions
  BEGIN SELECT RAISE(ABORT, 'report revisions are never deleted'); END;
CREATE TABLE report_approvals (
  id          INTEGER PRIMARY KEY,
  subject     TEXT NOT NULL,
  revision    INTEGER NOT NULL,
  approved_by TEXT NOT NULL,
  token_id    INTEGER NOT NULL,
  approved_at TEXT NOT NULL,
  pdf         BLOB NOT NULL,
  UNIQUE (subject, revision)
);
CREATE TRIGGER report_approvals_immutable BEFORE UPDATE ON report_approvals
  BEGIN SELECT RAISE(ABORT, 'report approvals are immutable'); END;
CREATE TRIGGER report_approvals_kept BEFORE DELETE ON report_approvals
  BEGIN SELECT RAISE(ABORT, 'report approvals are never deleted'); END;
)sql",
    // 14: the machine definition a finished job produced, exactly as it was written (saved as a
    // model unchanged).
    R"sql(
ALTER TABLE jobs ADD COLUMN machine_document TEXT NOT NULL DEFAULT '';
)sql",
};

constexpr int kSchemaVersion = static_cast<int>(sizeof(kMigrations) / sizeof(kMigrations[0]));

}  // namespace

int SchemaVersion() {
  return kSchemaVersion;
}

void Migrate(sqlite3* db) {
  int version = 0;
  {
    Statement s(db, "PRAGMA user_version");
    if (s.Step()) version = static_cast<int>(s.Int(0));
  }
  if (version > kSchemaVersion) {
    throw StorageError("storage: the database schema version " + std::to_string(version) +
                           " is newer than this program knows (" + std::to_string(kSchemaVersion) +
                           "); refusing to touch it",
                       SQLITE_ERROR, false);
  }
  for (int v = version; v < kSchemaVersion; ++v) {
    Transaction tx(db);
    Exec(db, kMigrations[v]);
    Exec(db, ("PRAGMA user_version=" + std::to_string(v + 1)).c_str());
    tx.Commit();
  }
}

}  // namespace km::server::sqlite
