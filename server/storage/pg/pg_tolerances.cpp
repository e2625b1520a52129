// Tolerance tables in the PostgreSQL backend: table tolerance_tables (migration 11), one row a
// version, appended only (triggers refuse UPDATE, DELETE and TRUNCATE).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

constexpr const char* kToleranceColumns =
    "machine_id, version, created_at, tolerances_json, sha256";

ToleranceTableRecord ReadToleranceRow(const pg::Result& s, int i) {
  ToleranceTableRecord r;
  r.machine_id = s.Text(i, 0);
  r.version = s.Int(i, 1);
  r.created_at = s.Text(i, 2);
  r.tolerances_json = s.Text(i, 3);
  r.sha256 = s.Text(i, 4);
  return r;
}

}  // namespace

ToleranceTablePut PgStorage::PutToleranceTable(const NewToleranceTable& t) {
  pg::Params key;
  key.Key(t.machine_id, "machine_id");
  auto c = pool_->Acquire();
  pg::Transaction tx(*c);
  // Writers of the same machine's table (in any instance) take turns until their transaction
  // ends: the next version number is read and used under the lock.
  c->Query("SELECT pg_advisory_xact_lock(hashtextextended($1, 11))", key, "lock tolerances");
  std::int64_t newest = 0;
  {
    const pg::Result s = c->Query(std::string("SELECT ") + kToleranceColumns +
                                      " FROM tolerance_tables WHERE machine_id = $1 "
                                      "ORDER BY version DESC LIMIT 1",
                                  key, "read tolerance table");
    if (s.Rows() > 0) {
      ToleranceTableRecord r = ReadToleranceRow(s, 0);
      if (r.sha256 == t.sha256) return ToleranceTablePut{std::move(r), false};
      newest = r.version;
    }
  }
  ToleranceTableRecord r{t.machine_id, newest + 1, NowUtcIso8601(), t.tolerances_json, t.sha256};
  pg::Params p;
  p.Text(r.machine_id, "machine_id").Int(r.version).Text(r.created_at, "created_at");
  p.Text(r.tolerances_json, "tolerances").Text(r.sha256, "sha256");
  c->Query(
      "INSERT INTO tolerance_tables (machine_id, version, created_at, tolerances_json, sha256) "
      "VALUES ($1, $2, $3, $4, $5)",
      p, "store tolerance table");
  tx.Commit();
  return ToleranceTablePut{std::move(r), true};
}

std::optional<ToleranceTableRecord> PgStorage::GetToleranceTable(
    const std::string& machine_id, std::optional<std::int64_t> version) {
  auto c = pool_->Acquire();
  pg::Params p;
  p.Text(machine_id, "machine_id");
  if (version) {
    p.Int(*version);
  } else {
    p.Null();
  }
  const pg::Result s =
      c->Query(std::string("SELECT ") + kToleranceColumns +
                   " FROM tolerance_tables WHERE machine_id = $1 AND "
                   "($2::BIGINT IS NULL OR version = $2) ORDER BY version DESC LIMIT 1",
               p, "read tolerance table", true);
  if (s.Rows() == 0) return std::nullopt;
  return ReadToleranceRow(s, 0);
}

}  // namespace km::server
