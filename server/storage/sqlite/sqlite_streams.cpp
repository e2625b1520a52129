// Capacitance-sensor streams in the SQLite backend: tables streams, stream_chunks (immutable,
// one row a chunk of consecutive counters) and stream_gaps (migration 3).
#include <sqlite3.h>

#include "analysis/core/errors.h"
#include "server/base/time_util.h"
#include "server/storage/sqlite/sqlite_db.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

using sqlite::Statement;
using sqlite::Transaction;

StreamRecord ReadStream(const Statement& s) {
  return StreamRecord{StreamId(s.Int(0)), s.Text(1), s.Text(2), s.Text(3), s.Text(4), s.Text(5)};
}
constexpr const char* kStreamColumns = "id, machine_id, name, source, metadata_json, created_at";
}  // namespace

StreamId SqliteStorage::CreateStream(const NewStream& st) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "INSERT INTO streams (machine_id, name, source, metadata_json, created_at) "
      "VALUES (?, ?, ?, ?, ?)");
  s->Bind(1, st.machine_id).Bind(2, st.name).Bind(3, st.source).Bind(4, st.metadata_json);
  s->Bind(5, NowUtcIso8601());
  s->Step();
  return StreamId(sqlite3_last_insert_rowid(db_));
}

std::optional<StreamRecord> SqliteStorage::GetStream(StreamId id) {
  std::lock_guard lock(mu_);
  auto s = Prepared((std::string("SELECT ") + kStreamColumns + " FROM streams WHERE id = ?"));
  s->Bind(1, id);
  if (!s->Step()) return std::nullopt;
  return ReadStream(*s);
}

std::vector<StreamRecord> SqliteStorage::ListStreams(const std::optional<std::string>& machine_id,
                                                     std::int64_t limit) {
  std::lock_guard lock(mu_);
  auto s =
      Prepared((std::string("SELECT ") + kStreamColumns +
                " FROM streams WHERE (?1 IS NULL OR machine_id = ?1) ORDER BY id DESC LIMIT ?2"));
  s->Bind(1, machine_id).Bind(2, limit);
  std::vector<StreamRecord> out;
  while (s->Step()) out.push_back(ReadStream(*s));
  return out;
}

void SqliteStorage::AppendStream(const std::vector<StreamChunk>& chunks,
                                 const std::vector<StreamGap>& gaps) {
  if (chunks.empty() && gaps.empty()) return;
  std::lock_guard lock(mu_);
  Transaction tx(db_);
  if (!chunks.empty()) {
    auto s = Prepared(
        "INSERT INTO stream_chunks (stream_id, channel, first_counter, n, t_first_us, "
        "t_last_us, value_min, value_max, value_sum, flagged, data) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    for (const auto& c : chunks) {
      s->Reset();
      s->Bind(1, c.stream_id).Bind(2, c.channel).Bind(3, c.first_counter).Bind(4, c.n);
      s->Bind(5, c.t_first_us).Bind(6, c.t_last_us).BindReal(7, c.value_min);
      s->BindReal(8, c.value_max).BindReal(9, c.value_sum).Bind(10, c.flagged);
      s->BindBlob(11, c.data);
      if (!s->TryStep()) {
        throw InvalidInput("", 0, "counter",
                           "channel " + std::to_string(c.channel) + " counter " +
                               std::to_string(c.first_counter) + " of stream " +
                               to_string(c.stream_id) + " is stored already");
      }
    }
  }
  if (!gaps.empty()) {
    auto s = Prepared(
        "INSERT INTO stream_gaps (stream_id, channel, first_missing, missing, t_before_us, "
        "t_after_us, detected_at) VALUES (?, ?, ?, ?, ?, ?, ?)");
    const std::string now = NowUtcIso8601();
    for (const auto& g : gaps) {
      s->Reset();
      s->Bind(1, g.stream_id).Bind(2, g.channel).Bind(3, g.first_missing).Bind(4, g.missing);
      s->Bind(5, g.t_before_us)
          .Bind(6, g.t_after_us)
          .Bind(7, g.detected_at.empty() ? now : g.detected_at);
      s->Step();
    }
  }
  tx.Commit();
}

std::vector<StreamChannelSummary> SqliteStorage::StreamChannels(StreamId stream_id) {
  std::lock_guard lock(mu_);
  std::vector<StreamChannelSummary> out;
  {
    auto s = Prepared(
        "SELECT channel, SUM(n), COUNT(*), SUM(flagged), MIN(t_first_us), MAX(t_last_us), "
        "MAX(first_counter + (n - 1)) FROM stream_chunks WHERE stream_id = ? GROUP BY channel "
        "ORDER BY channel");
    s->Bind(1, stream_id);
    while (s->Step()) {
      StreamChannelSummary c;
      c.channel = s->Int(0);
      c.samples = s->Int(1);
      c.chunks = s->Int(2);
      c.flagged = s->Int(3);
      c.first_t_us = s->Int(4);
      c.last_t_us = s->Int(5);
      c.next_counter = static_cast<std::uint64_t>(s->Int(6)) + 1;
      out.push_back(c);
    }
  }
  auto g = Prepared(
      "SELECT channel, COUNT(*), SUM(missing) FROM stream_gaps WHERE stream_id = ? "
      "GROUP BY channel");
  g->Bind(1, stream_id);
  while (g->Step()) {
    for (auto& c : out) {
      if (c.channel == g->Int(0)) {
        c.gaps = g->Int(1);
        c.missing = g->Int(2);
      }
    }
  }
  return out;
}

std::vector<StreamChunk> SqliteStorage::ReadStreamChunks(StreamId stream_id, std::int64_t channel,
                                                         std::int64_t from_us, std::int64_t to_us,
                                                         bool with_data) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      with_data ? "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                  "value_max, value_sum, flagged, data FROM stream_chunks WHERE stream_id = ? "
                  "AND channel = ? AND t_last_us >= ? AND t_first_us < ? ORDER BY first_counter"
                : "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                  "value_max, value_sum, flagged FROM stream_chunks WHERE stream_id = ? "
                  "AND channel = ? AND t_last_us >= ? AND t_first_us < ? ORDER BY first_counter");
  s->Bind(1, stream_id).Bind(2, channel).Bind(3, from_us).Bind(4, to_us);
  std::vector<StreamChunk> out;
  while (s->Step()) {
    StreamChunk c;
    c.stream_id = stream_id;
    c.channel = s->Int(0);
    c.first_counter = s->Int(1);
    c.n = s->Int(2);
    c.t_first_us = s->Int(3);
    c.t_last_us = s->Int(4);
    c.value_min = s->Real(5);
    c.value_max = s->Real(6);
    c.value_sum = s->Real(7);
    c.flagged = s->Int(8);
    if (with_data) c.data = s->Blob(9);
    out.push_back(std::move(c));
  }
  return out;
}

std::string SqliteStorage::ReadStreamChunkData(StreamId stream_id, std::int64_t channel,
                                               std::int64_t first_counter) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "SELECT data FROM stream_chunks WHERE stream_id = ? AND channel = ? AND "
      "first_counter = ?");
  s->Bind(1, stream_id).Bind(2, channel).Bind(3, first_counter);
  if (!s->Step()) throw NotFound("no stream chunk at that counter");
  return s->Blob(0);
}

std::vector<StreamGap> SqliteStorage::StreamGaps(StreamId stream_id, std::int64_t limit) {
  std::lock_guard lock(mu_);
  auto s = Prepared(
      "SELECT channel, first_missing, missing, t_before_us, t_after_us, detected_at "
      "FROM stream_gaps WHERE stream_id = ? ORDER BY t_before_us, channel LIMIT ?");
  s->Bind(1, stream_id).Bind(2, limit);
  std::vector<StreamGap> out;
  while (s->Step()) {
    out.push_back(
        StreamGap{stream_id, s->Int(0), s->Int(1), s->Int(2), s->Int(3), s->Int(4), s->Text(5)});
  }
  return out;
}

}  // namespace km::server
