// Machine definitions in the SQLite backend: table machine_models (migration 4), one row a
// version, appended only (triggers refuse UPDATE and DELETE).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

using sqlite::Statement;
using sqlite::Transaction;

constexpr const char* kModelColumns = "machine_id, version, created_at, source, note, sha256";

MachineModelRecord ReadModel(const Statement& s) {
  MachineModelRecord r;
  r.machine_id = s.Text(0);
  r.version = s.Int(1);
  r.created_at = s.Text(2);
  r.source = s.Text(3);
  r.note = s.Text(4);
  r.sha256 = s.Text(5);
  return r;
}

}  // namespace

MachineModelPut SqliteStorage::PutMachineModel(const NewMachineModel& m) {
  std::lock_guard lock(mu_);
  Transaction tx(db_);  // BEGIN IMMEDIATE: no other writer between reading and appending
  std::int64_t newest = 0;
  {
    auto s = Prepared((std::string("SELECT ") + kModelColumns +
                       " FROM machine_models WHERE machine_id = ? ORDER BY version DESC LIMIT 1"));
    s->Bind(1, m.machine_id);
    if (s->Step()) {
      MachineModelRecord r = ReadModel(*s);
      if (r.sha256 == m.sha256) return MachineModelPut{std::move(r), false};
      newest = r.version;
    }
  }
  MachineModelRecord r;
  r.machine_id = m.machine_id;
  r.version = newest + 1;
  r.created_at = NowUtcIso8601();
  r.source = m.source;
  r.note = m.note;
  r.sha256 = m.sha256;
  auto s = Prepared(
      "INSERT INTO machine_models (machine_id, version, created_at, source, note, document, "
      "sha256) VALUES (?, ?, ?, ?, ?, ?, ?)");
  s->Bind(1, r.machine_id).Bind(2, r.version).Bind(3, r.created_at).Bind(4, r.source);
  s->Bind(5, r.note).BindBlob(6, m.document).Bind(7, r.sha256);
  s->Step();
  tx.Commit();
  return MachineModelPut{std::move(r), true};
}

std::optional<MachineModelRecord> SqliteStorage::GetMachineModel(
    const std::string& machine_id, std::optional<std::int64_t> version) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kModelColumns +
                     ", document FROM machine_models WHERE machine_id = ?1 AND (?2 IS NULL OR "
                     "version = ?2) ORDER BY version DESC LIMIT 1"));
  s->Bind(1, machine_id);
  if (version) s->Bind(2, *version);
  if (!s->Step()) return std::nullopt;
  MachineModelRecord r = ReadModel(*s);
  r.document = s->Blob(6);
  return r;
}

std::vector<MachineModelRecord> SqliteStorage::ListMachineModels(const std::string& machine_id) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kModelColumns +
                     " FROM machine_models WHERE machine_id = ? ORDER BY version"));
  s->Bind(1, machine_id);
  std::vector<MachineModelRecord> out;
  while (s->Step()) out.push_back(ReadModel(*s));
  return out;
}

}  // namespace km::server
