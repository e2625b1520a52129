// The instrument register in the PostgreSQL backend: table instruments (migration 12), one row
// a version of a serial, appended only (triggers refuse UPDATE, DELETE and TRUNCATE).
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

constexpr const char* kInstrumentColumns = "serial, version, created_at, instrument_json, sha256";

InstrumentVersionRecord ReadInstrumentRow(const pg::Result& s, int i) {
  InstrumentVersionRecord r;
  r.serial = s.Text(i, 0);
  r.version = s.Int(i, 1);
  r.created_at = s.Text(i, 2);
  r.instrument_json = s.Text(i, 3);
  r.sha256 = s.Text(i, 4);
  return r;
}

}  // namespace

InstrumentVersionPut PgStorage::PutInstrument(const NewInstrumentVersion& t) {
  pg::Params key;
  key.Key(t.serial, "serial");
  auto c = pool_->Acquire();
  pg::Transaction tx(*c);
  // Writers of the same serial (in any instance) take turns until their transaction ends: the
  // next version number is read and used under the lock.
  c->Query("SELECT pg_advisory_xact_lock(hashtextextended($1, 12))", key, "lock instrument");
  std::int64_t newest = 0;
  {
    const pg::Result s = c->Query(std::string("SELECT ") + kInstrumentColumns +
                                      " FROM instruments WHERE serial = $1 "
                                      "ORDER BY version DESC LIMIT 1",
                                  key, "read instrument");
    if (s.Rows() > 0) {
      InstrumentVersionRecord r = ReadInstrumentRow(s, 0);
      if (r.sha256 == t.sha256) return InstrumentVersionPut{std::move(r), false};
      newest = r.version;
    }
  }
  InstrumentVersionRecord r{t.serial, newest + 1, NowUtcIso8601(), t.instrument_json, t.sha256};
  pg::Params p;
  p.Text(r.serial, "serial").Int(r.version).Text(r.created_at, "created_at");
  p.Text(r.instrument_json, "instrument").Text(r.sha256, "sha256");
  c->Query(
      "INSERT INTO instruments (serial, version, created_at, instrument_json, sha256) "
      "VALUES ($1, $2, $3, $4, $5)",
      p, "store instrument");
  tx.Commit();
  return InstrumentVersionPut{std::move(r), true};
}

std::optional<InstrumentVersionRecord> PgStorage::GetInstrument(
    const std::string& serial, std::optional<std::int64_t> version) {
  auto c = pool_->Acquire();
  pg::Params p;
  p.Text(serial, "serial");
  if (version) {
    p.Int(*version);
  } else {
    p.Null();
  }
  const pg::Result s = c->Query(std::string("SELECT ") + kInstrumentColumns +
                                    " FROM instruments WHERE serial = $1 AND "
                                    "($2::BIGINT IS NULL OR version = $2) "
                                    "ORDER BY version DESC LIMIT 1",
                                p, "read instrument", true);
  if (s.Rows() == 0) return std::nullopt;
  return ReadInstrumentRow(s, 0);
}

std::vector<InstrumentVersionRecord> PgStorage::ListInstruments() {
  auto c = pool_->Acquire();
  const pg::Result s = c->Query(std::string("SELECT DISTINCT ON (serial) ") + kInstrumentColumns +
                                    " FROM instruments ORDER BY serial, version DESC",
                                pg::Params{}, "list instruments", true);
  std::vector<InstrumentVersionRecord> out;
  for (int i = 0; i < s.Rows(); ++i) out.push_back(ReadInstrumentRow(s, i));
  return out;
}

}  // namespace km::server
