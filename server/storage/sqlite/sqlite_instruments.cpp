// The instrument register in the SQLite backend: table instruments (migration 12), one row a
// version of a serial, appended only (triggers refuse UPDATE and DELETE).
#include <sqlite3.h>

#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

constexpr const char* kInstrumentColumns = "serial, version, created_at, instrument_json, sha256";

InstrumentVersionRecord ReadInstrumentRow(const sqlite::Statement& s) {
  InstrumentVersionRecord r;
  r.serial = s.Text(0);
  r.version = s.Int(1);
  r.created_at = s.Text(2);
  r.instrument_json = s.Text(3);
  r.sha256 = s.Text(4);
  return r;
}

}  // namespace

InstrumentVersionPut SqliteStorage::PutInstrument(const NewInstrumentVersion& t) {
  std::lock_guard lock(mu_);
  sqlite::Transaction tx(db_);  // BEGIN IMMEDIATE: no other writer between reading and appending
  std::int64_t newest = 0;
  {
    auto s = Prepared(std::string("SELECT ") + kInstrumentColumns +
                      " FROM instruments WHERE serial = ? ORDER BY version DESC LIMIT 1");
    s->Bind(1, t.serial);
    if (s->Step()) {
      InstrumentVersionRecord r = ReadInstrumentRow(*s);
      if (r.sha256 == t.sha256) return InstrumentVersionPut{std::move(r), false};
      newest = r.version;
    }
  }
  InstrumentVersionRecord r{t.serial, newest + 1, NowUtcIso8601(), t.instrument_json, t.sha256};
  auto s = Prepared(
      "INSERT INTO instruments (serial, version, created_at, instrument_json, sha256) "
      "VALUES (?, ?, ?, ?, ?)");
  s->Bind(1, r.serial).Bind(2, r.version).Bind(3, r.created_at);
  s->Bind(4, r.instrument_json).Bind(5, r.sha256);
  s->Step();
  tx.Commit();
  return InstrumentVersionPut{std::move(r), true};
}

std::optional<InstrumentVersionRecord> SqliteStorage::GetInstrument(
    const std::string& serial, std::optional<std::int64_t> version) {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kInstrumentColumns +
                    " FROM instruments WHERE serial = ?1 AND (?2 IS NULL OR version = ?2) "
                    "ORDER BY version DESC LIMIT 1");
  s->Bind(1, serial);
  if (version) s->Bind(2, *version);
  if (!s->Step()) return std::nullopt;
  return ReadInstrumentRow(*s);
}

std::vector<InstrumentVersionRecord> SqliteStorage::ListInstruments() {
  std::lock_guard lock(mu_);
  auto s = Prepared(std::string("SELECT ") + kInstrumentColumns +
                    " FROM instruments AS i WHERE version = (SELECT MAX(version) FROM "
                    "instruments WHERE serial = i.serial) ORDER BY serial");
  std::vector<InstrumentVersionRecord> out;
  while (s->Step()) out.push_back(ReadInstrumentRow(*s));
  return out;
}

}  // namespace km::server
