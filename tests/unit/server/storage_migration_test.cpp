// Databases of every earlier schema version (tests/fixtures/schema/vN.sql, frozen as an older
// release left them) are migrated by opening them, with nothing lost: every row reads back
// through the storage interface, and the migrated schema is the one a new database gets.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

std::string FixturePath(int version) {
  return std::string(KINEMETRIC_SOURCE_DIR) + "/tests/fixtures/schema/v" + std::to_string(version) +
         ".sql";
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs SQL on a database file with the plain SQLite API (no storage code involved).
void RunSql(const std::string& db_path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  const std::string msg = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(db);
  ASSERT_EQ(rc, SQLITE_OK) << msg;
}

// Rows of a query, each row's columns joined by '|'.
std::vector<std::string> Rows(const std::string& db_path, const std::string& query) {
  sqlite3* db = nullptr;
  std::vector<std::string> out;
  if (sqlite3_open(db_path.c_str(), &db) != SQLITE_OK) return out;
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db, query.c_str(), -1, &s, nullptr) == SQLITE_OK) {
    while (sqlite3_step(s) == SQLITE_ROW) {
      std::string row;
      for (int c = 0; c < sqlite3_column_count(s); ++c) {
        const auto* t = sqlite3_column_text(s, c);
        row += (c ? "|" : "") + std::string(t ? reinterpret_cast<const char*>(t) : "NULL");
      }
      out.push_back(row);
    }
  }
  sqlite3_finalize(s);
  sqlite3_close(db);
  return out;
}

constexpr const char* kSchemaQuery =
    "SELECT type, name, tbl_name, sql FROM sqlite_master ORDER BY type, name";

class StorageMigration : public test::TempDirTest {
 protected:
  // A database file holding fixture vN, before any storage code has touched it.
  std::string OldDatabase(int version) {
    const std::string path = Path("v" + std::to_string(version) + ".db");
    const std::string sql = ReadFile(FixturePath(version));
    EXPECT_FALSE(sql.empty()) << FixturePath(version);
    RunSql(path, sql);
    return path;
  }
};

TEST_F(StorageMigration, EveryEarlierSchemaVersionHasAFixture) {
  ASSERT_GE(SqliteStorage::SchemaVersion(), 2);
  for (int v = 1; v < SqliteStorage::SchemaVersion(); ++v) {
    EXPECT_FALSE(ReadFile(FixturePath(v)).empty()) << "no fixture " << FixturePath(v);
    const std::string path = OldDatabase(v);
    EXPECT_EQ(Rows(path, "PRAGMA user_version"), std::vector<std::string>{std::to_string(v)});
  }
}

TEST_F(StorageMigration, MigratedSchemaIsTheSchemaOfANewDatabase) {
  const std::string fresh = Path("fresh.db");
  { SqliteStorage s(fresh); }
  const auto want = Rows(fresh, kSchemaQuery);
  ASSERT_FALSE(want.empty());
  for (int v = 1; v < SqliteStorage::SchemaVersion(); ++v) {
    const std::string path = OldDatabase(v);
    { SqliteStorage s(path); }
    EXPECT_EQ(Rows(path, kSchemaQuery), want) << "from version " << v;
    EXPECT_EQ(Rows(path, "PRAGMA user_version"),
              std::vector<std::string>{std::to_string(SqliteStorage::SchemaVersion())});
  }
}

// Version 1: measurements (raw bytes, samples, metadata), results, tokens.
void ExpectVersion1Rows(SqliteStorage& s) {
  const auto m1 = s.GetMeasurement(MeasurementId(1));
  ASSERT_TRUE(m1);
  EXPECT_EQ(m1->sha256, "a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1a1");
  EXPECT_EQ(m1->kind, "dbb");
  EXPECT_EQ(m1->format, "kinemetric-dbb/1");
  EXPECT_EQ(m1->machine_id, "old-vmc");
  EXPECT_EQ(m1->test_id, "t1");
  EXPECT_EQ(m1->direction, "ccw");
  EXPECT_EQ(m1->measured_at, std::optional<std::string>("2025-03-01T08:00:00Z"));
  EXPECT_EQ(m1->uploaded_at, "2025-03-02T09:30:00Z");
  EXPECT_EQ(m1->filename, "old.dbb");
  EXPECT_EQ(m1->sample_count, 3);
  EXPECT_EQ(m1->metadata_json, R"({"bar_length_mm":"150"})");
  EXPECT_EQ(s.GetRaw(MeasurementId(1)),
            "# format: kinemetric-dbb/1\n# machine_id: old-vmc\n# test_id: t1\n# direction: "
            "ccw\nangle_deg,dr_um\n0,1.5\n90,-0.25\n180,2\n");
  const auto samples = s.GetSamples(MeasurementId(1));
  EXPECT_EQ(samples.columns, (std::vector<std::string>{"angle_deg", "dr_um"}));
  EXPECT_EQ(samples.values, (std::vector<double>{0, 1.5, 90, -0.25, 180, 2}));
  EXPECT_EQ(s.FindBySha256("b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2b2"),
            std::optional<MeasurementId>(2));
  const auto m2 = s.GetMeasurement(MeasurementId(2));
  ASSERT_TRUE(m2);
  EXPECT_FALSE(m2->measured_at);
  EXPECT_EQ(s.GetSamples(MeasurementId(2)).values, (std::vector<double>{0, 0, 10, 1.25}));

  const auto r1 = s.GetResults(MeasurementId(1));
  ASSERT_EQ(r1.size(), 1u);
  EXPECT_EQ(r1[0].analysis, "dbb");
  EXPECT_EQ(r1[0].analysis_version, "dbb/1.0");
  EXPECT_EQ(r1[0].created_at, "2025-03-02T09:30:00Z");
  EXPECT_EQ(r1[0].result_json, R"({"circularity_um":2.25})");
  ASSERT_EQ(s.GetResults(MeasurementId(2)).size(), 1u);

  const auto page = s.ListMeasurements({});
  EXPECT_EQ(page.total, 2);
  MeasurementFilter vmc;
  vmc.machine_id = "old-vmc";
  EXPECT_EQ(s.ListMeasurements(vmc).total, 1);
  EXPECT_EQ(s.CountTokens(), 1);
  EXPECT_EQ(s.FindTokenRole("c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3"),
            std::optional<std::string>("admin"));
}

// Version 2: jobs.
void ExpectVersion2Rows(SqliteStorage& s) {
  const auto jobs = s.ListJobs(10);
  ASSERT_GE(jobs.size(), 2u);  // the fixture of version 8 adds a third
  EXPECT_EQ(jobs.back().id, JobId(1));
  const auto done = s.GetJob(JobId(1));
  ASSERT_TRUE(done);
  EXPECT_EQ(done->status, JobStatus::kDone);
  EXPECT_EQ(done->progress, 1.0);
  EXPECT_EQ(done->stage, "finished");
  EXPECT_EQ(done->request_json, R"({"measurement_ids":[1]})");
  EXPECT_EQ(done->result_json, R"({"rms_um":0.5})");
  EXPECT_EQ(done->created_at, "2025-04-01T10:00:00Z");
  const auto failed = s.GetJob(JobId(2));
  ASSERT_TRUE(failed);
  EXPECT_EQ(failed->status, JobStatus::kFailed);
  EXPECT_EQ(failed->progress, 0.25);
  EXPECT_EQ(failed->error, "not observable");
}

// Version 3: streams, chunks, gaps.
void ExpectVersion3Rows(SqliteStorage& s) {
  const auto st = s.GetStream(StreamId(1));
  ASSERT_TRUE(st);
  EXPECT_EQ(st->machine_id, "old-vmc");
  EXPECT_EQ(st->name, "spindle");
  EXPECT_EQ(st->source, "http");
  EXPECT_EQ(st->created_at, "2025-05-01T12:00:00Z");
  const auto channels = s.StreamChannels(StreamId(1));
  ASSERT_EQ(channels.size(), 1u);
  EXPECT_EQ(channels[0].samples, 6);
  EXPECT_EQ(channels[0].chunks, 2);
  EXPECT_EQ(channels[0].flagged, 1);
  EXPECT_EQ(channels[0].first_t_us, 1000);
  EXPECT_EQ(channels[0].last_t_us, 12000);
  EXPECT_EQ(channels[0].next_counter, 12u);
  EXPECT_EQ(channels[0].gaps, 1);
  EXPECT_EQ(channels[0].missing, 6);
  const auto chunks = s.ReadStreamChunks(StreamId(1), 0, 0, 1'000'000, true);
  ASSERT_EQ(chunks.size(), 2u);
  EXPECT_EQ(chunks[0].value_min, -1.5);
  EXPECT_EQ(chunks[0].value_max, 2.5);
  EXPECT_EQ(chunks[0].value_sum, 3.0);
  EXPECT_EQ(chunks[0].data, std::string("\x00\x01\x02\x03", 4));
  EXPECT_EQ(s.ReadStreamChunkData(StreamId(1), 0, 10), "\x04\x05");
  const auto gaps = s.StreamGaps(StreamId(1), 10);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_EQ(gaps[0].first_missing, 4);
  EXPECT_EQ(gaps[0].missing, 6);
  EXPECT_EQ(gaps[0].t_before_us, 4000);
  EXPECT_EQ(gaps[0].t_after_us, 11000);
  EXPECT_EQ(gaps[0].detected_at, "2025-05-01T12:00:01Z");
}

// Version 4: machine definitions, versioned.
void ExpectVersion4Rows(SqliteStorage& s) {
  const auto m = s.GetMachineModel("old-lathe", std::nullopt);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->version, 1);
  EXPECT_EQ(m->created_at, "2025-06-01T08:00:00Z");
  EXPECT_EQ(m->source, "upload");
  EXPECT_EQ(m->note, "first");
  EXPECT_EQ(m->document, R"({"format":"kinemetric-machine/1"})");
}

// Version 6: token expiry and revocation, the audit log of state-changing requests.
void ExpectVersion6Rows(SqliteStorage& s) {
  const auto token =
      s.FindToken("c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3");
  ASSERT_TRUE(token);
  EXPECT_EQ(token->name, "bootstrap");
  EXPECT_FALSE(token->expires_at);
  EXPECT_FALSE(token->revoked_at);
  const auto log = s.ListAudit(10, 0);
  ASSERT_EQ(log.total, 1);
  EXPECT_EQ(log.items[0].at, "2025-08-01T07:00:00Z");
  EXPECT_EQ(log.items[0].token_id, TokenId(1));
  EXPECT_EQ(log.items[0].method, "DELETE");
  EXPECT_EQ(log.items[0].path, "/api/v1/tokens/2");
  EXPECT_EQ(log.items[0].status, 200);
  EXPECT_EQ(log.items[0].subject, "token 2");
}

// Version 7: accuracy audits (a machine's rules and schedule, a verdict).
void ExpectVersion7Rows(SqliteStorage& s) {
  const auto c = s.GetAuditConfig("old-lathe");
  ASSERT_TRUE(c);
  EXPECT_EQ(c->schedule, "every 24h");
  EXPECT_EQ(c->last_run_at, "2025-09-01T06:00:00Z");
  EXPECT_EQ(c->next_run_at, "2025-09-02T06:00:00Z");
  const auto v = s.GetAuditVerdict(AuditVerdictId(1));
  ASSERT_TRUE(v);
  EXPECT_EQ(v->machine_id, "old-lathe");
  EXPECT_EQ(v->level, 2);
  EXPECT_EQ(v->trigger, "schedule");
  EXPECT_EQ(v->webhook_status, "delivered");
  EXPECT_EQ(v->webhook_attempts, 1);
}

// Version 8: a finished job with its plan, the instance that ran it and its attempts; jobs of
// earlier versions have no owner (version 9), and a job queued now keeps its owner.
void ExpectVersion8Rows(SqliteStorage& s) {
  const auto j = s.GetJob(JobId(3));
  ASSERT_TRUE(j);
  EXPECT_EQ(j->status, JobStatus::kDone);
  EXPECT_EQ(j->plan_json, R"({"measurement_ids":[1]})");
  EXPECT_EQ(j->lease_owner, "old-host:41:0badcafe");
  EXPECT_EQ(j->attempts, 2);
  EXPECT_FALSE(j->owner_token_id);
  EXPECT_FALSE(s.CancelJob(JobId(3), "too late"));
}

void ExpectJobOwnersKept(SqliteStorage& s) {
  const auto id = s.QueueJob(NewJob{"discovery", "{}", "{}", TokenId(1)});
  EXPECT_EQ(s.GetJob(id)->owner_token_id, TokenId(1));
  EXPECT_TRUE(s.CancelJob(id, "not wanted"));
  EXPECT_EQ(s.GetJob(id)->status, JobStatus::kCancelled);
}

// Jobs of earlier versions carry no plan and no lease (version 8): finished ones keep their
// outcome, and the queue offers none of them.
void ExpectJobsWithoutPlan(SqliteStorage& s) {
  const auto j = s.GetJob(JobId(1));
  ASSERT_TRUE(j);
  EXPECT_EQ(j->status, JobStatus::kDone);
  EXPECT_EQ(j->result_json, R"({"rms_um":0.5})");
  EXPECT_EQ(j->plan_json, "");
  EXPECT_EQ(j->lease_owner, "");
  EXPECT_EQ(j->attempts, 0);
  EXPECT_FALSE(s.ClaimJob("instance-a", 1'000'000, 1000, 3, "abandoned"));
}

// Tokens of earlier versions have no last use (version 10); a use is recorded after the
// migration, and an earlier time never replaces a later one.
void ExpectTokenUseRecorded(SqliteStorage& s) {
  ASSERT_FALSE(s.ListTokens().empty());
  EXPECT_FALSE(s.ListTokens()[0].last_used_at);
  s.TouchToken(TokenId(1), "2026-01-02T03:04:05Z");
  s.TouchToken(TokenId(1), "2026-01-01T00:00:00Z");
  EXPECT_EQ(s.ListTokens()[0].last_used_at, std::optional<std::string>("2026-01-02T03:04:05Z"));
  const auto t = s.FindToken("c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3c3");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->last_used_at, std::optional<std::string>("2026-01-02T03:04:05Z"));
}

// Accuracy audits (version 7) are usable at once after a migration.
void ExpectAccuracyAuditsUsable(SqliteStorage& s) {
  EXPECT_FALSE(s.GetAuditConfig("old-vmc"));
  AuditConfigRecord c;
  c.machine_id = "old-vmc";
  c.schedule = "every 24h";
  c.rules_json = "[]";
  c.next_run_at = "2025-09-01T06:00:00Z";
  s.PutAuditConfig(c);
  ASSERT_TRUE(s.GetAuditConfig("old-vmc"));
  EXPECT_EQ(s.GetAuditConfig("old-vmc")->schedule, c.schedule);
  AuditVerdictRecord v;
  v.machine_id = "old-vmc";
  v.level = 2;
  v.trigger = "manual";
  v.verdict_json = R"({"findings":[],"checked":[]})";
  const auto id = s.AddAuditVerdict(v);
  ASSERT_TRUE(s.GetAuditVerdict(id));
  EXPECT_EQ(s.GetAuditVerdict(id)->level, 2);
}

TEST_F(StorageMigration, EveryRowOfEveryEarlierVersionReadsBackAfterMigration) {
  for (int v = 1; v < SqliteStorage::SchemaVersion(); ++v) {
    SCOPED_TRACE("from schema version " + std::to_string(v));
    const std::string path = OldDatabase(v);
    {
      SqliteStorage s(path);
      ExpectVersion1Rows(s);
      if (v >= 2) ExpectVersion2Rows(s);
      if (v >= 3) ExpectVersion3Rows(s);
      if (v >= 4) ExpectVersion4Rows(s);
      if (v >= 6) ExpectVersion6Rows(s);
      if (v >= 7) ExpectVersion7Rows(s);
      if (v >= 8) ExpectVersion8Rows(s);
      if (v >= 2) ExpectJobsWithoutPlan(s);
      ExpectAccuracyAuditsUsable(s);
      ExpectTokenUseRecorded(s);
      // Tables a migration added are usable at once.
      NewMachineModel m{"old-vmc", "upload", "after migration", "{}", std::string(64, 'd')};
      EXPECT_EQ(s.PutMachineModel(m).record.version, 1);
      // Tolerance tables (version 11).
      EXPECT_FALSE(s.GetToleranceTable("old-vmc", std::nullopt));
      EXPECT_EQ(s.PutToleranceTable({"old-vmc", "[]", std::string(64, 'e')}).record.version, 1);
      EXPECT_EQ(s.ListMachines().size(), 2u);
      // The instrument register (version 12) keeps its rows.
      if (v >= 12) {
        const auto i = s.GetInstrument("QC20-4711", std::nullopt);
        ASSERT_TRUE(i);
        EXPECT_EQ(i->version, 1);
        EXPECT_EQ(i->created_at, "2025-11-01T08:00:00Z");
      }
      // Report revisions and approvals (version 13) keep their rows, the approved PDF byte for
      // byte.
      if (v >= 13) {
        const auto revs = s.ListReportRevisions("measurement 2");
        ASSERT_EQ(revs.size(), 1u);
        EXPECT_EQ(revs[0].created_at, "2025-12-01T08:00:00Z");
        ASSERT_TRUE(revs[0].approval);
        EXPECT_EQ(revs[0].approval->approved_by, "ann");
        EXPECT_EQ(s.ReportApprovalPdf("measurement 2", 1), std::string("%PDF-1.4\n"));
      }
      // Jobs finished before version 14 have no machine document.
      if (v >= 2) {
        EXPECT_EQ(s.GetJob(JobId(1))->machine_document, "");
      }
      // Report revisions (version 13) are usable at once.
      EXPECT_EQ(s.PutReportRevision({"measurement 1", std::string(64, 'f'), "{}"}).record.revision,
                1);
      EXPECT_TRUE(s.AddReportApproval(
          {"measurement 1", 1, "ann", TokenId(1), "", std::string("%PDF\0x", 6)}));
      EXPECT_EQ(s.ReportApprovalPdf("measurement 1", 1), std::string("%PDF\0x", 6));
      if (v < 2) {
        EXPECT_TRUE(s.ListJobs(10).empty());
      }
      if (v < 3) {
        EXPECT_FALSE(s.GetStream(StreamId(1)));
      }
      ExpectJobOwnersKept(s);  // after the checks of an empty queue
    }
    // Opening the migrated database again changes nothing.
    SqliteStorage again(path);
    ExpectVersion1Rows(again);
    EXPECT_EQ(again.ListMachineModels("old-vmc").size(), 1u);
  }
}

TEST_F(StorageMigration, MeasurementsStayImmutableAfterMigration) {
  const std::string path = OldDatabase(1);
  { SqliteStorage s(path); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "UPDATE measurements SET kind = 'x'", nullptr, nullptr, nullptr),
            SQLITE_OK);
  EXPECT_NE(sqlite3_exec(db, "DELETE FROM measurements", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  SqliteStorage s(path);
  EXPECT_EQ(s.ListMeasurements({}).total, 2);
}

}  // namespace
}  // namespace km::server
