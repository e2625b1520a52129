// Machine definitions in the PostgreSQL backend: table machine_models (migration 4), one row a
// version, appended only (triggers refuse UPDATE and DELETE).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;
using pg::Transaction;

constexpr const char* kModelColumns = "machine_id, version, created_at, source, note, sha256";

MachineModelRecord ReadModel(const Result& s, int i) {
  MachineModelRecord r;
  r.machine_id = s.Text(i, 0);
  r.version = s.Int(i, 1);
  r.created_at = s.Text(i, 2);
  r.source = s.Text(i, 3);
  r.note = s.Text(i, 4);
  r.sha256 = s.Text(i, 5);
  return r;
}

}  // namespace

MachineModelPut PgStorage::PutMachineModel(const NewMachineModel& m) {
  MachineModelRecord r;
  r.machine_id = m.machine_id;
  r.source = m.source;
  r.note = m.note;
  r.sha256 = m.sha256;
  Params key;
  key.Key(m.machine_id, "machine_id");
  auto c = pool_->Acquire();
  Transaction tx(*c);
  // Writers of the same machine (in any instance) take turns until their transaction ends: the
  // next version number is read and used under the lock.
  c->Query("SELECT pg_advisory_xact_lock(hashtextextended($1, 4))", key, "lock machine model");
  {
    const Result s = c->Query(std::string("SELECT ") + kModelColumns +
                                  " FROM machine_models WHERE machine_id = $1 "
                                  "ORDER BY version DESC LIMIT 1",
                              key, "read machine model");
    if (s.Rows() > 0) {
      MachineModelRecord newest = ReadModel(s, 0);
      if (newest.sha256 == m.sha256) return MachineModelPut{std::move(newest), false};
      r.version = newest.version;
    }
  }
  ++r.version;
  r.created_at = NowUtcIso8601();
  Params p;
  p.Text(r.machine_id, "machine_id").Int(r.version).Text(r.created_at, "created_at");
  p.Text(r.source, "source").Text(r.note, "note").Bytes(m.document).Text(r.sha256, "sha256");
  c->Query(
      "INSERT INTO machine_models (machine_id, version, created_at, source, note, document, "
      "sha256) VALUES ($1, $2, $3, $4, $5, $6, $7)",
      p, "store machine model");
  tx.Commit();
  return MachineModelPut{std::move(r), true};
}

std::optional<MachineModelRecord> PgStorage::GetMachineModel(const std::string& machine_id,
                                                             std::optional<std::int64_t> version) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(machine_id, "machine_id");
  if (version) {
    p.Int(*version);
  } else {
    p.Null();
  }
  const Result s =
      c->Query(std::string("SELECT ") + kModelColumns +
                   ", document FROM machine_models WHERE machine_id = $1 AND "
                   "($2::BIGINT IS NULL OR version = $2) ORDER BY version DESC LIMIT 1",
               p, "read machine model", true);
  if (s.Rows() == 0) return std::nullopt;
  MachineModelRecord r = ReadModel(s, 0);
  r.document = s.Bytes(0, 6);
  return r;
}

std::vector<MachineModelRecord> PgStorage::ListMachineModels(const std::string& machine_id) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(machine_id, "machine_id");
  const Result s = c->Query(std::string("SELECT ") + kModelColumns +
                                " FROM machine_models WHERE machine_id = $1 ORDER BY version",
                            p, "list machine models");
  std::vector<MachineModelRecord> out;
  for (int i = 0; i < s.Rows(); ++i) out.push_back(ReadModel(s, i));
  return out;
}

}  // namespace km::server
