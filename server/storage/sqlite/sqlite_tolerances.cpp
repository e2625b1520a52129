// Tolerance tables in the SQLite backend: table tolerance_tables (migration 11), one row a
// version, appended only (triggers refuse UPDATE and DELETE).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

constexpr const char* kToleranceColumns =
    "machine_id, version, created_at, tolerances_json, sha256";

ToleranceTableRecord ReadToleranceTable(const sqlite::Statement& s) {
  ToleranceTableRecord r;
  r.machine_id = s.Text(0);
  r.version = s.Int(1);
  r.created_at = s.Text(2);
  r.tolerances_json = s.Text(3);
  r.sha256 = s.Text(4);
  return r;
}

}  // namespace

ToleranceTablePut SqliteStorage::PutToleranceTable(const NewToleranceTable& t) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);  // BEGIN IMMEDIATE: no other writer between reading and appending
  std::int64_t newest = 0;
  {
    auto s = Prepared(std::string("SELECT ") + kToleranceColumns +
                      " FROM tolerance_tables WHERE machine_id = ? ORDER BY version DESC LIMIT 1");
    s->Bind(1, t.machine_id);
    if (s->Step()) {
      ToleranceTableRecord r = ReadToleranceTable(*s);
      if (r.sha256 == t.sha256) return ToleranceTablePut{std::move(r), false};
      newest = r.version;
    }
  }
  ToleranceTableRecord r{t.machine_id, newest + 1, NowUtcIso8601(), t.tolerances_json, t.sha256};
  auto s = Prepared(
      "INSERT INTO tolerance_tables (machine_id, version, created_at, tolerances_json, sha256) "
      "VALUES (?, ?, ?, ?, ?)");
  s->Bind(1, r.machine_id).Bind(2, r.version).Bind(3, r.created_at);
  s->Bind(4, r.tolerances_json).Bind(5, r.sha256);
  s->Step();
  tx.Commit();
  return ToleranceTablePut{std::move(r), true};
}

std::optional<ToleranceTableRecord> SqliteStorage::GetToleranceTable(
    const std::string& machine_id, std::optional<std::int64_t> version) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kToleranceColumns +
                    " FROM tolerance_tables WHERE machine_id = ?1 AND (?2 IS NULL OR "
                    "version = ?2) ORDER BY version DESC LIMIT 1");
  s->Bind(1, machine_id);
  if (version) s->Bind(2, *version);
  if (!s->Step()) return std::nullopt;
  return ReadToleranceTable(*s);
}

}  // namespace km::server
