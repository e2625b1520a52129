// Every method of the storage interface on both backends, SQLite and PostgreSQL, with the same
// expected answers: the same ids, orders, counts, errors and deduplication.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <vector>

#include "analysis/core/errors.h"
#include "server/storage/pg/pg_storage.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/storage_backends.h"

namespace km::server {
namespace {

using test::Backends;

TEST_P(Backends, StoresOnceAndKeepsEverythingAcrossReopen) {
  MeasurementId id;
  {
    auto s = Open();
    const auto a = s->PutMeasurement(Sample("a1", "m1"), {{"dbb", "dbb/1", R"({"x":1})"}});
    EXPECT_TRUE(a.created);
    EXPECT_EQ(a.id, MeasurementId(1));
    id = a.id;
    const auto again = s->PutMeasurement(Sample("a1", "m1"), {{"dbb", "dbb/1", R"({"x":2})"}});
    EXPECT_FALSE(again.created);
    EXPECT_EQ(again.id, id);
    EXPECT_EQ(s->PutMeasurement(Sample("b2", "m2"), {}).id, MeasurementId(2));
  }
  auto s = Open();
  const auto rec = s->GetMeasurement(id);
  ASSERT_TRUE(rec);
  EXPECT_EQ(rec->sha256, "a1");
  EXPECT_EQ(rec->kind, "dbb");
  EXPECT_EQ(rec->format, "kinemetric-dbb/1");
  EXPECT_EQ(rec->machine_id, "m1");
  EXPECT_EQ(rec->test_id, "t");
  EXPECT_EQ(rec->direction, "ccw");
  EXPECT_EQ(rec->measured_at, "2026-01-02T00:00:00Z");  // 'a' % 8 = 1
  EXPECT_EQ(rec->uploaded_at.size(), 20u);
  EXPECT_EQ(rec->metadata_json, "{}");
  EXPECT_EQ(rec->sample_count, 3);
  EXPECT_FALSE(s->GetMeasurement(MeasurementId(3)));
  EXPECT_EQ(s->FindBySha256("b2"), MeasurementId(2));
  EXPECT_FALSE(s->FindBySha256("zz"));
  EXPECT_EQ(s->GetRaw(id), "raw bytes a1");
  const auto block = s->GetSamples(id);
  EXPECT_EQ(block.columns, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(block.Column(1), (std::vector<double>{2, 4, 6}));
  const auto results = s->GetResults(id);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].result_json, R"({"x":1})");  // the first stored result is kept
  EXPECT_EQ(results[0].input_sha256, "a1");
  EXPECT_EQ(results[0].analysis_version, "dbb/1");
  EXPECT_EQ(s->ListMachines().size(), 2u);
  MeasurementFilter f;
  f.machine_id = "m2";
  EXPECT_EQ(s->ListMeasurements(f).total, 1);
  EXPECT_THROW(s->GetRaw(MeasurementId(999)), NotFound);
  EXPECT_THROW(s->GetSamples(MeasurementId(999)), NotFound);
}

TEST_P(Backends, ResultsAddedLaterKeepTheOlderOnes) {
  auto s = Open();
  const auto id = s->PutMeasurement(Sample("r1", "m"), {{"dbb", "dbb/1", "{}"}}).id;
  const AnswerBasis first = s->GetAnswerBasis(id);
  EXPECT_EQ(first.results.count, 1);
  EXPECT_GT(first.results.newest_id, 0);
  EXPECT_EQ(first.table_version, 0);  // machine "m" has no tolerance table
  s->PutResult(id, {"dbb", "dbb/2", R"({"v":2})"});
  // Every append changes the basis, as another instance on the same database reads it.
  const AnswerBasis second = Open()->GetAnswerBasis(id);
  EXPECT_EQ(second.results.count, 2);
  EXPECT_GT(second.results.newest_id, first.results.newest_id);
  s->PutResult(id, {"dbb", "dbb/2", R"({"v":3})"});  // the same version again: kept as it was
  EXPECT_EQ(s->GetAnswerBasis(id), second);
  s->PutResult(id, {"form", "form/1", "[]"});
  EXPECT_EQ(s->GetAnswerBasis(id).results.count, 3);
  // A table of the measurement's machine (not of another) is in the basis.
  s->PutToleranceTable({"other", "[]", "sha-a"});
  EXPECT_EQ(s->GetAnswerBasis(id).table_version, 0);
  s->PutToleranceTable({"m", "[]", "sha-a"});
  s->PutToleranceTable({"m", "[1]", "sha-b"});
  EXPECT_EQ(Open()->GetAnswerBasis(id).table_version, 2);
  EXPECT_EQ(s->GetAnswerBasis(MeasurementId(id.value() + 1)), AnswerBasis{});
  const auto r = s->GetResults(id);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0].analysis_version, "dbb/1");
  EXPECT_EQ(r[1].analysis_version, "dbb/2");
  EXPECT_EQ(r[1].result_json, R"({"v":2})");
  EXPECT_EQ(r[2].analysis, "form");
  for (const auto& x : r) EXPECT_EQ(x.measurement_id, id);
  EXPECT_THROW(s->PutResult(MeasurementId(id.value() + 1), {"dbb", "dbb/1", "{}"}), NotFound);
  EXPECT_TRUE(s->GetResults(MeasurementId(id.value() + 1)).empty());
}

TEST_P(Backends, ListsPageNewestFirstAndFindByFreeTextAndId) {
  auto s = Open();
  // 12 tests of one machine measured one per day, uploaded in a shuffled order; one of another.
  const int day_of[] = {7, 2, 11, 5, 1, 9, 3, 12, 8, 4, 10, 6};
  std::map<int, MeasurementId> id_of_day;
  for (const int day : day_of) {
    NewMeasurement m = Sample("s" + std::to_string(day), "m1");
    m.measured_at =
        "2026-03-" + std::string(day < 10 ? "0" : "") + std::to_string(day) + "T08:00:00Z";
    m.filename = "Run_" + std::to_string(day) + (day % 2 ? "_CW.txt" : "_ccw.txt");
    m.direction = day % 2 ? "cw" : "ccw";
    m.kind = day == 12 ? "straightness" : "dbb";
    id_of_day[day] = s->PutMeasurement(m, {}).id;
  }
  s->PutMeasurement(Sample("other", "m2"), {});
  MeasurementFilter f;
  f.machine_id = "m1";
  f.order = MeasurementFilter::Order::kNewest;
  f.limit = 5;
  auto page = s->ListMeasurements(f);
  EXPECT_EQ(page.total, 12);
  ASSERT_EQ(page.items.size(), 5u);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(page.items[k].id, id_of_day[12 - k]) << k;
  f.offset = 10;
  page = s->ListMeasurements(f);
  ASSERT_EQ(page.items.size(), 2u);
  EXPECT_EQ(page.total, 12);
  EXPECT_EQ(page.items[0].id, id_of_day[2]);
  EXPECT_EQ(page.items[1].id, id_of_day[1]);
  f.offset = 0;
  f.order = MeasurementFilter::Order::kOldest;
  EXPECT_EQ(s->ListMeasurements(f).items[0].id, id_of_day[1]);
  f.order = MeasurementFilter::Order::kUploaded;
  EXPECT_EQ(s->ListMeasurements(f).items[0].id, id_of_day[6]);
  f.limit = 50;
  f.text = "_cw";
  page = s->ListMeasurements(f);
  EXPECT_EQ(page.total, 6);
  for (const auto& r : page.items) EXPECT_EQ(r.direction, "cw") << r.filename;
  f.text = "STRAIGHT";
  page = s->ListMeasurements(f);
  ASSERT_EQ(page.total, 1);
  EXPECT_EQ(page.items[0].id, id_of_day[12]);
  f.text = "#" + to_string(id_of_day[9]);
  page = s->ListMeasurements(f);
  ASSERT_EQ(page.total, 1);
  EXPECT_EQ(page.items[0].id, id_of_day[9]);
  f.text = to_string(id_of_day[9]);  // without '#': id 6, and the name Run_6_ccw.txt
  EXPECT_EQ(id_of_day[9], MeasurementId(6));
  EXPECT_EQ(s->ListMeasurements(f).total, 2);
  f.text = "no such thing";
  EXPECT_EQ(s->ListMeasurements(f).total, 0);
  f.text = "%";
  EXPECT_EQ(s->ListMeasurements(f).total, 0);
  f.text = "n_1";
  EXPECT_EQ(s->ListMeasurements(f).total, 4);
  f.text.reset();
  f.order = MeasurementFilter::Order::kOldest;
  f.kind = "dbb";
  f.from = "2026-03-03T08:00:00Z";
  f.to = "2026-03-06T08:00:00Z";
  page = s->ListMeasurements(f);
  ASSERT_EQ(page.total, 3);
  EXPECT_EQ(page.items[0].id, id_of_day[3]);
  EXPECT_EQ(page.items[2].id, id_of_day[5]);
  // Without a machine: every machine; direction and test filters; the other machine's file.
  MeasurementFilter all;
  all.limit = 3;
  page = s->ListMeasurements(all);
  EXPECT_EQ(page.total, 13);
  EXPECT_EQ(page.items[0].machine_id, "m2");  // measured 2026-01-08: the oldest
  all.direction = "ccw";
  all.limit = 50;
  EXPECT_EQ(s->ListMeasurements(all).total, 7);
  all.test_id = "other test";
  EXPECT_EQ(s->ListMeasurements(all).total, 0);
}

TEST_P(Backends, TextIsOrderedByteByByteAndCaseFoldingIsAsciiOnly) {
  auto s = Open();
  // Byte order, not a locale's: "B" < "a" < "b" < "É" (0xC3 0x89).
  for (const std::string m : {"b", "É", "B", "a"}) s->PutMeasurement(Sample(m + "h", m), {});
  const auto machines = s->ListMachines();
  ASSERT_EQ(machines.size(), 4u);
  EXPECT_EQ(machines[0].machine_id, "B");
  EXPECT_EQ(machines[1].machine_id, "a");
  EXPECT_EQ(machines[2].machine_id, "b");
  EXPECT_EQ(machines[3].machine_id, "É");
  NewMeasurement m = Sample("u1", "m");
  m.filename = "Été.txt";
  s->PutMeasurement(m, {});
  MeasurementFilter f;
  f.text = "été";  // É and é differ: only ASCII letters fold
  EXPECT_EQ(s->ListMeasurements(f).total, 0);
  f.text = "ÉTÉ.TXT";
  EXPECT_EQ(s->ListMeasurements(f).total, 0);
  f.text = "Été.TXT";
  EXPECT_EQ(s->ListMeasurements(f).total, 1);
  // LIKE's special characters are taken literally.
  m = Sample("u2", "m");
  m.filename = "a\\b_%c.txt";
  s->PutMeasurement(m, {});
  for (const std::string t : {"\\", "\\B_%", "_%c", "a\\b"}) {
    f.text = t;
    EXPECT_EQ(s->ListMeasurements(f).total, 1) << t;
  }
  f.text = "a_b";
  EXPECT_EQ(s->ListMeasurements(f).total, 0);
}

TEST_P(Backends, InvalidUtf8IsAnsweredAsReplacementCharacters) {
  auto s = Open();
  NewMeasurement m = Sample("x1", "m");
  m.filename = std::string("bad\xff\xfe.txt");
  const auto id = s->PutMeasurement(m, {}).id;
  EXPECT_EQ(s->GetMeasurement(id)->filename, "bad\xEF\xBF\xBD\xEF\xBF\xBD.txt");
}

TEST_P(Backends, ExactBytesOfEveryValueRoundTrip) {
  auto s = Open();
  NewMeasurement m = Sample("big", "m");
  m.raw.resize(20u << 20);
  for (std::size_t i = 0; i < m.raw.size(); ++i) {
    m.raw[i] = static_cast<char>((i * 7 + (i >> 8)) & 0xff);
  }
  m.samples.columns = {"x"};
  m.samples.values = {0.1, -0.0, std::numeric_limits<double>::denorm_min(),
                      std::numeric_limits<double>::max(), 1.0 / 3.0};
  const auto id = s->PutMeasurement(m, {}).id;
  const std::string raw = s->GetRaw(id);
  EXPECT_EQ(raw.size(), m.raw.size());
  EXPECT_TRUE(raw == m.raw);
  const auto back = s->GetSamples(id);
  ASSERT_EQ(back.values.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(std::memcmp(&back.values[i], &m.samples.values[i], sizeof(double)), 0) << i;
  }
  std::string every(256, '\0');
  for (int b = 0; b < 256; ++b) every[static_cast<std::size_t>(b)] = static_cast<char>(b);
  NewMachineModel model{"mm", "upload", "", every, "sha-every"};
  s->PutMachineModel(model);
  EXPECT_TRUE(s->GetMachineModel("mm", 1)->document == every);
}

TEST_P(Backends, MachineModelsAppendVersionsAndNeverOverwriteThem) {
  {
    auto s = Open();
    const auto v1 = s->PutMachineModel(Model("hx", "doc one"));
    EXPECT_TRUE(v1.created);
    EXPECT_EQ(v1.record.version, 1);
    EXPECT_EQ(v1.record.created_at.size(), 20u);
    const auto v2 = s->PutMachineModel(Model("hx", "doc two"));
    EXPECT_TRUE(v2.created);
    EXPECT_EQ(v2.record.version, 2);
    auto same = Model("hx", "doc two");
    same.source = "calibration job 9";
    const auto again = s->PutMachineModel(same);
    EXPECT_FALSE(again.created);
    EXPECT_EQ(again.record.version, 2);
    EXPECT_EQ(again.record.source, "upload");
    EXPECT_EQ(again.record.created_at, v2.record.created_at);
    const auto back = s->PutMachineModel(Model("hx", "doc one"));
    EXPECT_TRUE(back.created);
    EXPECT_EQ(back.record.version, 3);
    EXPECT_EQ(s->PutMachineModel(Model("other", "doc one")).record.version, 1);
  }
  auto s = Open();
  const auto newest = s->GetMachineModel("hx", std::nullopt);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->version, 3);
  EXPECT_EQ(newest->document, "doc one");
  const auto v2 = s->GetMachineModel("hx", 2);
  ASSERT_TRUE(v2);
  EXPECT_EQ(v2->document, "doc two");
  EXPECT_EQ(v2->note, "note of doc two");
  EXPECT_EQ(v2->sha256, "sha-doc two");
  EXPECT_EQ(v2->machine_id, "hx");
  EXPECT_FALSE(s->GetMachineModel("hx", 4));
  EXPECT_FALSE(s->GetMachineModel("nobody", std::nullopt));
  const auto list = s->ListMachineModels("hx");
  ASSERT_EQ(list.size(), 3u);
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(list[i].version, static_cast<std::int64_t>(i + 1));
    EXPECT_TRUE(list[i].document.empty());
  }
  EXPECT_TRUE(s->ListMachineModels("nobody").empty());
}

TEST_P(Backends, MachinesWithMeasurementsOrAModelAreListed) {
  auto s = Open();
  s->PutMeasurement(Sample("a", "vmc"), {});
  s->PutMeasurement(Sample("c", "vmc"), {});
  s->PutMachineModel(Model("hexapod", "one"));
  s->PutMachineModel(Model("hexapod", "two"));
  s->PutMachineModel(Model("vmc", "one"));
  const auto machines = s->ListMachines();
  ASSERT_EQ(machines.size(), 2u);
  EXPECT_EQ(machines[0].machine_id, "hexapod");
  EXPECT_EQ(machines[0].measurement_count, 0);
  EXPECT_FALSE(machines[0].last_time);
  EXPECT_EQ(machines[0].model_versions, 2);
  EXPECT_EQ(machines[1].machine_id, "vmc");
  EXPECT_EQ(machines[1].measurement_count, 2);
  EXPECT_EQ(machines[1].last_time, "2026-01-04T00:00:00Z");  // 'c' % 8 = 3
  EXPECT_EQ(machines[1].model_versions, 1);
}

TEST_P(Backends, JobsAreStoredUpdatedListedAndCounted) {
  auto s = Open();
  EXPECT_EQ(s->CreateJob("calibration", R"({"a":1})"), JobId(1));
  EXPECT_EQ(s->CreateJob("discovery", "{}").value(), 2);
  EXPECT_EQ(s->CreateJob("calibration", "{}").value(), 3);
  auto j = *s->GetJob(JobId(1));
  EXPECT_EQ(j.kind, "calibration");
  EXPECT_EQ(j.status, JobStatus::kQueued);
  EXPECT_EQ(j.progress, 0.0);
  EXPECT_EQ(j.request_json, R"({"a":1})");
  EXPECT_EQ(j.created_at.size(), 20u);
  j.status = JobStatus::kDone;
  j.progress = 0.1 + 0.2;  // not a round decimal: stored exactly
  j.stage = "fit";
  j.result_json = R"({"r":2})";
  s->UpdateJob(j);
  const auto back = *s->GetJob(JobId(1));
  EXPECT_EQ(back.status, JobStatus::kDone);
  EXPECT_EQ(back.progress, 0.1 + 0.2);
  EXPECT_EQ(back.stage, "fit");
  EXPECT_EQ(back.result_json, R"({"r":2})");
  EXPECT_FALSE(s->GetJob(JobId(4)));
  const auto list = s->ListJobs(2);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id.value(), 3);
  EXPECT_EQ(list[1].id.value(), 2);
  EXPECT_EQ(s->CountJobsByStatus(),
            (std::map<std::string, std::int64_t>{{"done", 1}, {"queued", 2}}));
  EXPECT_EQ(s->CountJobsWithStatus(JobStatus::kQueued), 2);
  EXPECT_EQ(s->CountJobsWithStatus(JobStatus::kDone), 1);
  EXPECT_EQ(s->CountJobsWithStatus(JobStatus::kRunning), 0);
  EXPECT_EQ(s->FailInterruptedJobs("stopped"), 2);
  EXPECT_EQ(s->GetJob(JobId(2))->error, "stopped");
  EXPECT_EQ(s->GetJob(JobId(1))->error, "");
  EXPECT_EQ(s->CountJobsByStatus(),
            (std::map<std::string, std::int64_t>{{"done", 1}, {"failed", 2}}));
  EXPECT_EQ(s->FailInterruptedJobs("again"), 0);
}

TEST_P(Backends, TokensAndTheAuditLog) {
  auto s = Open();
  EXPECT_EQ(s->CountTokens(), 0);
  s->PutToken("h1", "admin", "first");
  s->PutToken("h1", "viewer", "again");  // the same hash: kept as it was
  EXPECT_EQ(s->CountTokens(), 1);
  EXPECT_EQ(s->FindTokenRole("h1"), "admin");
  EXPECT_FALSE(s->FindTokenRole("h2"));
  EXPECT_EQ(s->AddToken("h2", "operator", "line 2", "2027-01-01T00:00:00Z"), TokenId(2));
  EXPECT_EQ(s->AddToken("h3", "viewer", "wall", std::nullopt).value(), 3);
  const auto t = *s->FindToken("h2");
  EXPECT_EQ(t.id.value(), 2);
  EXPECT_EQ(t.role, "operator");
  EXPECT_EQ(t.name, "line 2");
  EXPECT_EQ(t.expires_at, "2027-01-01T00:00:00Z");
  EXPECT_FALSE(t.revoked_at);
  EXPECT_FALSE(s->FindToken("nope"));
  const auto allow = [](const std::vector<TokenRecord>&) {};
  EXPECT_TRUE(s->RevokeToken(TokenId(2), allow));
  const auto first = s->FindToken("h2")->revoked_at;
  ASSERT_TRUE(first);
  EXPECT_TRUE(s->RevokeToken(TokenId(2), allow));
  EXPECT_EQ(s->FindToken("h2")->revoked_at, first);  // a second revocation keeps the first time
  EXPECT_FALSE(s->RevokeToken(TokenId(99), allow));
  // A check that refuses leaves the token as it was (the check sees every token).
  std::size_t seen = 0;
  EXPECT_THROW(s->RevokeToken(TokenId(3),
                              [&](const std::vector<TokenRecord>& all) {
                                seen = all.size();
                                throw std::runtime_error("refused");
                              }),
               std::runtime_error);
  EXPECT_EQ(seen, 3u);
  EXPECT_FALSE(s->FindToken("h3")->revoked_at);
  const auto list = s->ListTokens();
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0].name, "first");
  EXPECT_EQ(list[2].role, "viewer");
  EXPECT_FALSE(list[2].expires_at);
  // The last use: none until recorded; a later time replaces an earlier one, never the reverse.
  EXPECT_FALSE(list[2].last_used_at);
  s->TouchToken(TokenId(3), "2026-05-02T10:00:00Z");
  s->TouchToken(TokenId(3), "2026-05-01T10:00:00Z");
  EXPECT_EQ(s->FindToken("h3")->last_used_at, std::optional<std::string>("2026-05-02T10:00:00Z"));
  s->TouchToken(TokenId(3), "2026-05-03T10:00:00Z");
  EXPECT_EQ(s->ListTokens()[2].last_used_at, std::optional<std::string>("2026-05-03T10:00:00Z"));
  EXPECT_FALSE(s->ListTokens()[1].last_used_at);
  for (int i = 1; i <= 5; ++i) {
    AuditEntry e;
    e.at = i == 5 ? "" : "2026-05-0" + std::to_string(i) + "T00:00:00Z";
    e.token_id = i % 2 ? std::optional(TokenId(2)) : std::nullopt;
    e.token_name = i % 2 ? "line 2" : "";
    e.role = "operator";
    e.method = "POST";
    e.path = "/api/v1/x/" + std::to_string(i);
    e.status = 200 + i;
    e.subject = "job " + std::to_string(i);
    s->AppendAudit(e);
  }
  const auto page = s->ListAudit(2, 1);
  EXPECT_EQ(page.total, 5);
  ASSERT_EQ(page.items.size(), 2u);
  EXPECT_EQ(page.items[0].id, AuditEntryId(4));
  EXPECT_EQ(page.items[0].at, "2026-05-04T00:00:00Z");
  EXPECT_FALSE(page.items[0].token_id);
  EXPECT_EQ(page.items[0].status, 204);
  EXPECT_EQ(page.items[1].id.value(), 3);
  EXPECT_EQ(page.items[1].token_id, TokenId(2));
  EXPECT_EQ(page.items[1].path, "/api/v1/x/3");
  EXPECT_EQ(page.items[1].subject, "job 3");
  EXPECT_EQ(s->ListAudit(10, 0).items[0].at.size(), 20u);  // set by the storage
}

TEST_P(Backends, AccuracyAuditConfigsAndVerdicts) {
  auto s = Open();
  AuditConfigRecord c{"vmc", "daily 06:00", "[]", "", std::nullopt, "2026-06-02T06:00:00Z"};
  s->PutAuditConfig(c);
  s->PutAuditConfig({"a-first", std::nullopt, "[1]", "2026-06-01T00:00:00Z", {}, {}});
  EXPECT_EQ(s->GetAuditConfig("vmc")->schedule, "daily 06:00");
  EXPECT_EQ(s->GetAuditConfig("vmc")->updated_at.size(), 20u);
  c.rules_json = R"([{"rule":2}])";
  c.updated_at = "2026-06-01T12:00:00Z";
  s->PutAuditConfig(c);  // replaced
  const auto got = *s->GetAuditConfig("vmc");
  EXPECT_EQ(got.rules_json, R"([{"rule":2}])");
  EXPECT_EQ(got.updated_at, "2026-06-01T12:00:00Z");
  EXPECT_EQ(got.next_run_at, "2026-06-02T06:00:00Z");
  EXPECT_FALSE(got.last_run_at);
  EXPECT_FALSE(s->GetAuditConfig("none"));
  const auto all = s->ListAuditConfigs();
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].machine_id, "a-first");
  EXPECT_FALSE(all[0].schedule);
  s->SetAuditRun("vmc", "2026-06-02T06:00:01Z", "2026-06-03T06:00:00Z");
  s->SetAuditRun("vmc", std::nullopt, std::nullopt);  // last kept, next cleared
  EXPECT_EQ(s->GetAuditConfig("vmc")->last_run_at, "2026-06-02T06:00:01Z");
  EXPECT_FALSE(s->GetAuditConfig("vmc")->next_run_at);
  for (int i = 1; i <= 4; ++i) {
    AuditVerdictRecord v;
    v.machine_id = i == 4 ? "other" : "vmc";
    v.level = i == 2 ? 3 : 1;
    v.trigger = "manual";
    v.created_at = "2026-06-0" + std::to_string(i) + "T00:00:00Z";
    v.verdict_json = "{\"n\":" + std::to_string(i) + "}";
    EXPECT_EQ(s->AddAuditVerdict(v), AuditVerdictId(i));
  }
  s->SetAuditWebhook(AuditVerdictId(2), "delivered", 3);
  const auto v2 = *s->GetAuditVerdict(AuditVerdictId(2));
  EXPECT_EQ(v2.level, 3);
  EXPECT_EQ(v2.webhook_status, "delivered");
  EXPECT_EQ(v2.webhook_attempts, 3);
  EXPECT_EQ(v2.verdict_json, R"({"n":2})");
  EXPECT_FALSE(s->GetAuditVerdict(AuditVerdictId(5)));
  AuditVerdictFilter f;
  f.machine_id = "vmc";
  auto list = s->ListAuditVerdicts(f);
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0].id.value(), 3);
  EXPECT_EQ(list[2].id.value(), 1);
  f.machine_id.reset();
  f.from = "2026-06-02T00:00:00Z";
  f.to = "2026-06-04T00:00:00Z";
  list = s->ListAuditVerdicts(f);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id.value(), 3);
  EXPECT_EQ(list[1].id.value(), 2);
  f = AuditVerdictFilter{};
  f.limit = 1;
  EXPECT_EQ(s->ListAuditVerdicts(f).at(0).machine_id, "other");
  // Pages: an offset, and a byte budget that ends the page after the verdict taking the
  // verdict_json bytes past it (each verdict_json here is 7 bytes).
  const auto ids = [&](std::int64_t offset, std::optional<std::int64_t> max_bytes) {
    AuditVerdictFilter p;
    p.offset = offset;
    p.max_bytes = max_bytes;
    std::vector<std::int64_t> out;
    for (const auto& v : s->ListAuditVerdicts(p)) out.push_back(v.id.value());
    return out;
  };
  using Ids = std::vector<std::int64_t>;
  EXPECT_EQ(ids(1, std::nullopt), (Ids{3, 2, 1}));
  EXPECT_EQ(ids(1, 7), (Ids{3, 2}));
  EXPECT_EQ(ids(1, 6), (Ids{3}));
  EXPECT_EQ(ids(0, 0), (Ids{4}));
  EXPECT_EQ(ids(0, 14), (Ids{4, 3, 2}));
  EXPECT_EQ(ids(3, 1000), (Ids{1}));
  EXPECT_TRUE(ids(4, 1000).empty());
  f = AuditVerdictFilter{};
  f.limit = 2;
  f.offset = 1;
  f.max_bytes = 1000;
  EXPECT_EQ(s->ListAuditVerdicts(f).size(), 2u);
}

StreamChunk Chunk(std::int64_t stream, std::int64_t channel, std::int64_t first, std::int64_t n) {
  StreamChunk c;
  c.stream_id = StreamId(stream);
  c.channel = channel;
  c.first_counter = first;
  c.n = n;
  c.t_first_us = first * 1000;
  c.t_last_us = (first + n - 1) * 1000;
  c.value_min = -0.1 * static_cast<double>(first);
  c.value_max = 1e-310;  // subnormal: kept bit for bit
  c.value_sum = std::numeric_limits<double>::infinity();
  c.flagged = first % 3;
  c.data = std::string("\0\xff data ", 8) + std::to_string(first);
  return c;
}

TEST_P(Backends, StreamsChunksAndGaps) {
  auto s = Open();
  EXPECT_EQ(s->CreateStream({"m1", "run", "http", R"({"channels":[]})"}), StreamId(1));
  EXPECT_EQ(s->CreateStream({"m2", "", "modbus:dev", "{}"}).value(), 2);
  EXPECT_EQ(s->CreateStream({"m1", "second", "http", "{}"}).value(), 3);
  const auto st = *s->GetStream(StreamId(1));
  EXPECT_EQ(st.machine_id, "m1");
  EXPECT_EQ(st.name, "run");
  EXPECT_EQ(st.source, "http");
  EXPECT_EQ(st.metadata_json, R"({"channels":[]})");
  EXPECT_EQ(st.created_at.size(), 20u);
  EXPECT_FALSE(s->GetStream(StreamId(4)));
  auto list = s->ListStreams("m1", 10);
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id.value(), 3);
  EXPECT_EQ(s->ListStreams(std::nullopt, 2).size(), 2u);
  EXPECT_EQ(s->ListStreams(std::nullopt, 10).size(), 3u);
  s->AppendStream({Chunk(1, 0, 0, 10), Chunk(1, 0, 10, 10), Chunk(1, 1, 0, 5)},
                  {{StreamId(1), 0, 20, 5, 19000, 25000, "2026-07-01T00:00:00Z"}});
  s->AppendStream({Chunk(1, 0, 25, 10)}, {{StreamId(1), 1, 5, 2, 4000, 7000, ""}});
  // A chunk stored already: refused, and nothing of that call is written.
  EXPECT_THROW(s->AppendStream({Chunk(1, 0, 40, 10), Chunk(1, 0, 10, 10)}, {}), InvalidInput);
  s->AppendStream({}, {});
  const auto chans = s->StreamChannels(StreamId(1));
  ASSERT_EQ(chans.size(), 2u);
  EXPECT_EQ(chans[0].channel, 0);
  EXPECT_EQ(chans[0].samples, 30);
  EXPECT_EQ(chans[0].chunks, 3);
  EXPECT_EQ(chans[0].flagged, 0 + 1 + 1);
  EXPECT_EQ(chans[0].first_t_us, 0);
  EXPECT_EQ(chans[0].last_t_us, 34000);
  EXPECT_EQ(chans[0].next_counter, 35u);
  EXPECT_EQ(chans[0].gaps, 1);
  EXPECT_EQ(chans[0].missing, 5);
  EXPECT_EQ(chans[1].samples, 5);
  EXPECT_EQ(chans[1].missing, 2);
  EXPECT_TRUE(s->StreamChannels(StreamId(2)).empty());
  auto chunks = s->ReadStreamChunks(StreamId(1), 0, 9000, 25000, true);
  ASSERT_EQ(chunks.size(), 2u);  // [0, 9000] touches 9000; [25000, …] starts at the end
  EXPECT_EQ(chunks[0].first_counter, 0);
  EXPECT_EQ(chunks[1].first_counter, 10);
  EXPECT_EQ(chunks[1].data, Chunk(1, 0, 10, 10).data);
  EXPECT_EQ(chunks[1].value_min, Chunk(1, 0, 10, 10).value_min);
  EXPECT_EQ(chunks[1].value_max, 1e-310);
  EXPECT_EQ(chunks[1].value_sum, std::numeric_limits<double>::infinity());
  EXPECT_EQ(chunks[1].flagged, 1);
  EXPECT_EQ(chunks[1].t_last_us, 19000);
  chunks = s->ReadStreamChunks(StreamId(1), 0, std::numeric_limits<std::int64_t>::min(),
                               std::numeric_limits<std::int64_t>::max(), false);
  ASSERT_EQ(chunks.size(), 3u);
  EXPECT_TRUE(chunks[2].data.empty());
  EXPECT_EQ(chunks[2].first_counter, 25);
  EXPECT_EQ(s->ReadStreamChunkData(StreamId(1), 1, 0), Chunk(1, 1, 0, 5).data);
  EXPECT_THROW(s->ReadStreamChunkData(StreamId(1), 1, 1), NotFound);
  const auto gaps = s->StreamGaps(StreamId(1), 10);
  ASSERT_EQ(gaps.size(), 2u);
  EXPECT_EQ(gaps[0].channel, 1);  // by t_before_us
  EXPECT_EQ(gaps[0].first_missing, 5);
  EXPECT_EQ(gaps[0].detected_at.size(), 20u);
  EXPECT_EQ(gaps[1].detected_at, "2026-07-01T00:00:00Z");
  EXPECT_EQ(gaps[1].t_after_us, 25000);
  EXPECT_EQ(s->StreamGaps(StreamId(1), 1).size(), 1u);
}

}  // namespace
}  // namespace km::server
