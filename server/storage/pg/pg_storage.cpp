#include "server/storage/pg/pg_storage.h"

#include <algorithm>

#include "analysis/core/errors.h"
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_migrations.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;
using pg::Transaction;

MeasurementRecord ReadRecord(const Result& s, int row) {
  MeasurementRecord r;
  r.id = MeasurementId(s.Int(row, 0));
  r.sha256 = s.Text(row, 1);
  r.kind = s.Text(row, 2);
  r.format = s.Text(row, 3);
  r.machine_id = s.Text(row, 4);
  r.test_id = s.Text(row, 5);
  r.direction = s.Text(row, 6);
  r.measured_at = s.OptText(row, 7);
  r.uploaded_at = s.Text(row, 8);
  r.filename = s.Text(row, 9);
  r.sample_count = s.Int(row, 10);
  r.metadata_json = s.Text(row, 11);
  return r;
}

constexpr const char* kRecordColumns =
    "id, sha256, kind, format, machine_id, test_id, direction, measured_at, uploaded_at, "
    "filename, sample_count, metadata_json";

// The free-text part of a measurement filter: a LIKE pattern (%text% with % _ \ escaped) and,
// when the text is a number ("258" or "#258"), the id it names.
struct TextMatch {
  std::optional<std::string> pattern;
  std::optional<std::int64_t> id;
};

TextMatch ParseText(const std::optional<std::string>& text) {
  TextMatch t;
  if (!text || text->empty()) return t;
  t.pattern = "%";
  for (const char c : *text) {
    if (c == '%' || c == '_' || c == '\\') *t.pattern += '\\';
    *t.pattern += c;
  }
  *t.pattern += '%';
  const std::string digits = (*text)[0] == '#' ? text->substr(1) : *text;
  if (!digits.empty() && digits.size() <= 15 &&
      digits.find_first_not_of("0123456789") == std::string::npos) {
    t.id = std::stoll(digits);
  }
  return t;
}

// The WHERE clause of a measurement filter, its parameters added to p.
std::string FilterWhere(const MeasurementFilter& f, Params& p) {
  std::string where = " WHERE TRUE";
  if (f.machine_id) {
    where += " AND machine_id = $" + std::to_string(p.Text(*f.machine_id, "machine_id").size());
  }
  if (f.kind) where += " AND kind = $" + std::to_string(p.Text(*f.kind, "kind").size());
  if (f.test_id) where += " AND test_id = $" + std::to_string(p.Text(*f.test_id, "test_id").size());
  if (f.direction) {
    where += " AND direction = $" + std::to_string(p.Text(*f.direction, "direction").size());
  }
  if (f.from) {
    where += " AND COALESCE(measured_at, uploaded_at) >= $" +
             std::to_string(p.Text(*f.from, "from").size());
  }
  if (f.to) {
    where +=
        " AND COALESCE(measured_at, uploaded_at) < $" + std::to_string(p.Text(*f.to, "to").size());
  }
  const TextMatch t = ParseText(f.text);
  if (t.pattern) {
    // ILIKE on C-collated text folds ASCII letters only, as SQLite's LIKE does.
    const std::string n = std::to_string(p.Text(*t.pattern, "text").size());
    where += " AND (filename ILIKE $" + n + " OR test_id ILIKE $" + n + " OR direction ILIKE $" +
             n + " OR kind ILIKE $" + n;
    if (t.id) where += " OR id = $" + std::to_string(p.Int(*t.id).size());
    where += ")";
  }
  return where;
}

}  // namespace

int PgStorage::SchemaVersion() {
  return pg::SchemaVersion();
}

PgStorage::PgStorage(const std::string& url, PgOptions options) {
  pg::ConnOptions c;
  c.url = url;
  c.busy_timeout_ms = options.busy_timeout_ms;
  c.statement_timeout_ms = options.statement_timeout_ms;
  pool_ = std::make_unique<pg::Pool>(c, std::max(1, options.pool_size));
  {
    auto conn = pool_->Acquire();
    pg::Migrate(*conn);
  }
  pool_->Fill();
}

PgStorage::~PgStorage() = default;

namespace {

void InsertResult(pg::Conn& c, MeasurementId id, const std::string& sha, const NewResult& r) {
  Params p;
  p.Int(id).Text(r.analysis, "analysis").Text(r.analysis_version, "analysis_version");
  p.Text(sha, "sha256").Text(NowUtcIso8601(), "created_at").Text(r.result_json, "result_json");
  c.Query(
      "INSERT INTO results (measurement_id, analysis, analysis_version, input_sha256, "
      "created_at, result_json) VALUES ($1, $2, $3, $4, $5, $6) "
      "ON CONFLICT (measurement_id, analysis, analysis_version) DO NOTHING",
      p, "store result");
}

std::optional<MeasurementId> FindSha(pg::Conn& c, const std::string& sha256) {
  Params p;
  p.Text(sha256, "sha256");
  const Result r = c.Query("SELECT id FROM measurements WHERE sha256 = $1", p, "find measurement");
  if (r.Rows() == 0) return std::nullopt;
  return MeasurementId(r.Int(0, 0));
}

}  // namespace

PutOutcome PgStorage::PutMeasurement(const NewMeasurement& m,
                                     const std::vector<NewResult>& results) {
  auto c = pool_->Acquire();
  if (auto id = FindSha(*c, m.sha256)) return PutOutcome{*id, false};
  Params p;
  p.Text(m.sha256, "sha256").Text(m.kind, "kind").Text(m.format, "format");
  p.Key(m.machine_id, "machine_id").Text(m.test_id, "test_id").Text(m.direction, "direction");
  p.Text(m.measured_at, "measured_at").Text(NowUtcIso8601(), "uploaded_at");
  p.Text(m.filename, "filename").Int(static_cast<std::int64_t>(m.samples.rows()));
  p.Text(m.metadata_json, "metadata").Bytes(m.raw).Bytes(EncodeSamples(m.samples));
  Transaction tx(*c);
  // Another instance may store the same bytes at the same moment: the loser's insert waits
  // for the winner's transaction and then does nothing; its answer is the winner's id.
  const Result r = c->Query(
      "INSERT INTO measurements (sha256, kind, format, machine_id, test_id, direction, "
      "measured_at, uploaded_at, filename, sample_count, metadata_json, raw, samples) "
      "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) "
      "ON CONFLICT (sha256) DO NOTHING RETURNING id",
      p, "store measurement");
  if (r.Rows() == 0) {
    tx.Commit();  // nothing was written
    if (auto id = FindSha(*c, m.sha256)) return PutOutcome{*id, false};
    throw StorageError("storage: store measurement: a conflicting row vanished",
                       pg::SqlStateCode("40001"), true);
  }
  const MeasurementId id(r.Int(0, 0));
  for (const auto& res : results) InsertResult(*c, id, m.sha256, res);
  tx.Commit();
  return PutOutcome{id, true};
}

std::optional<MeasurementRecord> PgStorage::GetMeasurement(MeasurementId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r =
      c->Query(std::string("SELECT ") + kRecordColumns + " FROM measurements WHERE id = $1", p,
               "read measurement");
  if (r.Rows() == 0) return std::nullopt;
  return ReadRecord(r, 0);
}

std::optional<MeasurementId> PgStorage::FindBySha256(const std::string& sha256) {
  auto c = pool_->Acquire();
  return FindSha(*c, sha256);
}

std::string PgStorage::GetRaw(MeasurementId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r = c->Query("SELECT raw FROM measurements WHERE id = $1", p, "read raw", true);
  if (r.Rows() == 0) throw NotFound("measurement " + to_string(id) + " does not exist");
  return r.Bytes(0, 0);
}

SampleBlock PgStorage::GetSamples(MeasurementId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r =
      c->Query("SELECT samples FROM measurements WHERE id = $1", p, "read samples", true);
  if (r.Rows() == 0) throw NotFound("measurement " + to_string(id) + " does not exist");
  return DecodeSamples(r.Bytes(0, 0));
}

MeasurementPage PgStorage::ListMeasurements(const MeasurementFilter& f) {
  auto c = pool_->Acquire();
  Params p;
  const std::string where = FilterWhere(f, p);
  const char* order = " ORDER BY COALESCE(measured_at, uploaded_at), id";
  if (f.order == MeasurementFilter::Order::kNewest) {
    order = " ORDER BY COALESCE(measured_at, uploaded_at) DESC, id DESC";
  } else if (f.order == MeasurementFilter::Order::kUploaded) {
    order = " ORDER BY id DESC";
  }
  Params page_params;
  FilterWhere(f, page_params);
  const std::string limit = std::to_string(page_params.size() + 1);
  // SQLite reads a negative limit as none and a negative offset as 0.
  if (f.limit < 0) {
    page_params.Null();
  } else {
    page_params.Int(f.limit);
  }
  page_params.Int(std::max<std::int64_t>(0, f.offset));
  MeasurementPage page;
  const Result r =
      c->Query(std::string("SELECT ") + kRecordColumns + " FROM measurements" + where + order +
                   " LIMIT $" + limit + " OFFSET $" + std::to_string(page_params.size()),
               page_params, "list measurements");
  for (int i = 0; i < r.Rows(); ++i) page.items.push_back(ReadRecord(r, i));
  // A first page that is not full holds every match: no second pass to count them.
  if (f.offset <= 0 && (f.limit < 0 || static_cast<std::int64_t>(page.items.size()) < f.limit)) {
    page.total = static_cast<std::int64_t>(page.items.size());
    return page;
  }
  page.total =
      c->Query("SELECT COUNT(*) FROM measurements" + where, p, "count measurements").Int(0, 0);
  return page;
}

std::vector<ResultRecord> PgStorage::GetResults(MeasurementId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r = c->Query(
      "SELECT measurement_id, analysis, analysis_version, input_sha256, created_at, "
      "result_json FROM results WHERE measurement_id = $1 ORDER BY id",
      p, "read results");
  std::vector<ResultRecord> out;
  for (int i = 0; i < r.Rows(); ++i) {
    out.push_back(ResultRecord{MeasurementId(r.Int(i, 0)), r.Text(i, 1), r.Text(i, 2), r.Text(i, 3),
                               r.Text(i, 4), r.Text(i, 5)});
  }
  return out;
}

AnswerBasis PgStorage::GetAnswerBasis(MeasurementId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r = c->Query(
      "SELECT count(*), COALESCE(max(id), 0), COALESCE((SELECT max(version) FROM "
      "tolerance_tables WHERE machine_id = (SELECT machine_id FROM measurements WHERE id = $1)), "
      "0) FROM results WHERE measurement_id = $1",
      p, "read the answers' basis");
  return AnswerBasis{{r.Int(0, 0), r.Int(0, 1)}, r.Int(0, 2)};
}

void PgStorage::PutResult(MeasurementId id, const NewResult& res) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r = c->Query("SELECT sha256 FROM measurements WHERE id = $1", p, "read measurement");
  if (r.Rows() == 0) throw NotFound("measurement " + to_string(id) + " does not exist");
  InsertResult(*c, id, r.Text(0, 0), res);  // measurements are never deleted: no transaction
}

std::vector<MachineSummary> PgStorage::ListMachines() {
  auto c = pool_->Acquire();
  // Machines with measurements, with a stored model, or both.
  const Result r = c->Query(
      "SELECT machine_id, SUM(n)::BIGINT, MAX(t), SUM(v)::BIGINT FROM ("
      " SELECT machine_id, COUNT(*) AS n, MAX(COALESCE(measured_at, uploaded_at)) AS t,"
      " 0::BIGINT AS v FROM measurements GROUP BY machine_id"
      " UNION ALL"
      " SELECT machine_id, 0, NULL, MAX(version) FROM machine_models GROUP BY machine_id"
      ") AS m GROUP BY machine_id ORDER BY machine_id",
      "list machines");
  std::vector<MachineSummary> out;
  for (int i = 0; i < r.Rows(); ++i) {
    out.push_back(MachineSummary{r.Text(i, 0), r.Int(i, 1), r.OptText(i, 2), r.Int(i, 3)});
  }
  return out;
}

std::int64_t PgStorage::CountTokens() {
  auto c = pool_->Acquire();
  return c->Query("SELECT COUNT(*) FROM tokens", "count tokens").Int(0, 0);
}

void PgStorage::PutToken(const std::string& token_sha256, const std::string& role,
                         const std::string& label) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(token_sha256, "token").Text(role, "role").Text(label, "label");
  p.Text(NowUtcIso8601(), "created_at");
  c->Query(
      "INSERT INTO tokens (token_sha256, role, label, created_at) SELECT $1::TEXT, $2::TEXT, "
      "$3::TEXT, $4::TEXT "
      "WHERE NOT EXISTS (SELECT 1 FROM tokens WHERE token_sha256 = $1) "
      "ON CONFLICT (token_sha256) DO NOTHING",
      p, "store token");
}

std::optional<std::string> PgStorage::FindTokenRole(const std::string& token_sha256) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(token_sha256, "token");
  const Result r = c->Query("SELECT role FROM tokens WHERE token_sha256 = $1", p, "find token");
  if (r.Rows() == 0) return std::nullopt;
  return r.Text(0, 0);
}

}  // namespace km::server
