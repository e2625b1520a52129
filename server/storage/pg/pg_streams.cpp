// Capacitance-sensor streams in the PostgreSQL backend: tables streams, stream_chunks
// (immutable, one row a chunk of consecutive counters) and stream_gaps (migration 3).
#include "analysis/core/errors.h"
#include "server/base/time_util.h"
#include "server/storage/pg/pg_db.h"
#include "server/storage/pg/pg_storage.h"

namespace km::server {
namespace {

using pg::Params;
using pg::Result;
using pg::Transaction;

StreamRecord ReadStream(const Result& s, int i) {
  return StreamRecord{StreamId(s.Int(i, 0)), s.Text(i, 1), s.Text(i, 2),
                      s.Text(i, 3),          s.Text(i, 4), s.Text(i, 5)};
}
constexpr const char* kStreamColumns = "id, machine_id, name, source, metadata_json, created_at";

Params& Limit(Params& p, std::int64_t limit) {
  return limit < 0 ? p.Null() : p.Int(limit);  // SQLite: a negative limit is none
}

void InsertChunk(pg::Conn& c, const StreamChunk& ch) {
  Params p;
  p.Int(ch.stream_id).Int(ch.channel).Int(ch.first_counter).Int(ch.n);
  p.Int(ch.t_first_us).Int(ch.t_last_us).Real(ch.value_min).Real(ch.value_max);
  p.Real(ch.value_sum).Int(ch.flagged).Bytes(ch.data);
  if (!c.TryQuery("INSERT INTO stream_chunks (stream_id, channel, first_counter, n, t_first_us, "
                  "t_last_us, value_min, value_max, value_sum, flagged, data) "
                  "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11)",
                  p, "store stream chunk")) {
    throw InvalidInput("", 0, "counter",
                       "channel " + std::to_string(ch.channel) + " counter " +
                           std::to_string(ch.first_counter) + " of stream " +
                           to_string(ch.stream_id) + " is stored already");
  }
}

}  // namespace

StreamId PgStorage::CreateStream(const NewStream& st) {
  auto c = pool_->Acquire();
  Params p;
  p.Key(st.machine_id, "machine_id").Text(st.name, "name").Text(st.source, "source");
  p.Text(st.metadata_json, "metadata").Text(NowUtcIso8601(), "created_at");
  return StreamId(
      c->Query("INSERT INTO streams (machine_id, name, source, metadata_json, created_at) "
               "VALUES ($1, $2, $3, $4, $5) RETURNING id",
               p, "store stream")
          .Int(0, 0));
}

std::optional<StreamRecord> PgStorage::GetStream(StreamId id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(id);
  const Result r = c->Query(std::string("SELECT ") + kStreamColumns + " FROM streams WHERE id = $1",
                            p, "read stream");
  if (r.Rows() == 0) return std::nullopt;
  return ReadStream(r, 0);
}

std::vector<StreamRecord> PgStorage::ListStreams(const std::optional<std::string>& machine_id,
                                                 std::int64_t limit) {
  auto c = pool_->Acquire();
  Params p;
  p.Text(machine_id, "machine_id");
  Limit(p, limit);
  const Result r = c->Query(std::string("SELECT ") + kStreamColumns +
                                " FROM streams WHERE ($1::TEXT IS NULL OR machine_id = $1) "
                                "ORDER BY id DESC LIMIT $2",
                            p, "list streams");
  std::vector<StreamRecord> out;
  for (int i = 0; i < r.Rows(); ++i) out.push_back(ReadStream(r, i));
  return out;
}

void PgStorage::AppendStream(const std::vector<StreamChunk>& chunks,
                             const std::vector<StreamGap>& gaps) {
  if (chunks.empty() && gaps.empty()) return;
  auto c = pool_->Acquire();
  Transaction tx(*c);
  for (const auto& ch : chunks) InsertChunk(*c, ch);
  const std::string now = NowUtcIso8601();
  for (const auto& g : gaps) {
    Params p;
    p.Int(g.stream_id).Int(g.channel).Int(g.first_missing).Int(g.missing);
    p.Int(g.t_before_us).Int(g.t_after_us);
    p.Text(g.detected_at.empty() ? now : g.detected_at, "detected_at");
    c->Query(
        "INSERT INTO stream_gaps (stream_id, channel, first_missing, missing, t_before_us, "
        "t_after_us, detected_at) VALUES ($1, $2, $3, $4, $5, $6, $7)",
        p, "store stream gap");
  }
  tx.Commit();
}

std::vector<StreamChannelSummary> PgStorage::StreamChannels(StreamId stream_id) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(stream_id);
  const Result s = c->Query(
      "SELECT channel, SUM(n)::BIGINT, COUNT(*), SUM(flagged)::BIGINT, MIN(t_first_us), "
      "MAX(t_last_us), MAX(first_counter + (n - 1)) FROM stream_chunks WHERE stream_id = $1 "
      "GROUP BY channel ORDER BY channel",
      p, "stream channels");
  std::vector<StreamChannelSummary> out;
  for (int i = 0; i < s.Rows(); ++i) {
    StreamChannelSummary ch;
    ch.channel = s.Int(i, 0);
    ch.samples = s.Int(i, 1);
    ch.chunks = s.Int(i, 2);
    ch.flagged = s.Int(i, 3);
    ch.first_t_us = s.Int(i, 4);
    ch.last_t_us = s.Int(i, 5);
    ch.next_counter = static_cast<std::uint64_t>(s.Int(i, 6)) + 1;
    out.push_back(ch);
  }
  const Result g = c->Query(
      "SELECT channel, COUNT(*), SUM(missing)::BIGINT FROM stream_gaps WHERE stream_id = $1 "
      "GROUP BY channel",
      p, "stream gaps");
  for (int i = 0; i < g.Rows(); ++i) {
    for (auto& ch : out) {
      if (ch.channel == g.Int(i, 0)) {
        ch.gaps = g.Int(i, 1);
        ch.missing = g.Int(i, 2);
      }
    }
  }
  return out;
}

std::vector<StreamChunk> PgStorage::ReadStreamChunks(StreamId stream_id, std::int64_t channel,
                                                     std::int64_t from_us, std::int64_t to_us,
                                                     bool with_data) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(stream_id).Int(channel).Int(from_us).Int(to_us);
  const Result s = c->Query(
      with_data ? "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                  "value_max, value_sum, flagged, data FROM stream_chunks WHERE stream_id = $1 "
                  "AND channel = $2 AND t_last_us >= $3 AND t_first_us < $4 ORDER BY first_counter"
                : "SELECT channel, first_counter, n, t_first_us, t_last_us, value_min, "
                  "value_max, value_sum, flagged FROM stream_chunks WHERE stream_id = $1 "
                  "AND channel = $2 AND t_last_us >= $3 AND t_first_us < $4 ORDER BY first_counter",
      p, "read stream chunks", true);
  std::vector<StreamChunk> out;
  for (int i = 0; i < s.Rows(); ++i) {
    StreamChunk ch;
    ch.stream_id = stream_id;
    ch.channel = s.Int(i, 0);
    ch.first_counter = s.Int(i, 1);
    ch.n = s.Int(i, 2);
    ch.t_first_us = s.Int(i, 3);
    ch.t_last_us = s.Int(i, 4);
    ch.value_min = s.Real(i, 5);
    ch.value_max = s.Real(i, 6);
    ch.value_sum = s.Real(i, 7);
    ch.flagged = s.Int(i, 8);
    if (with_data) ch.data = s.Bytes(i, 9);
    out.push_back(std::move(ch));
  }
  return out;
}

std::string PgStorage::ReadStreamChunkData(StreamId stream_id, std::int64_t channel,
                                           std::int64_t first_counter) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(stream_id).Int(channel).Int(first_counter);
  const Result r = c->Query(
      "SELECT data FROM stream_chunks WHERE stream_id = $1 AND channel = $2 AND "
      "first_counter = $3",
      p, "read stream chunk", true);
  if (r.Rows() == 0) throw NotFound("no stream chunk at that counter");
  return r.Bytes(0, 0);
}

std::vector<StreamGap> PgStorage::StreamGaps(StreamId stream_id, std::int64_t limit) {
  auto c = pool_->Acquire();
  Params p;
  p.Int(stream_id);
  Limit(p, limit);
  const Result s = c->Query(
      "SELECT channel, first_missing, missing, t_before_us, t_after_us, detected_at "
      "FROM stream_gaps WHERE stream_id = $1 ORDER BY t_before_us, channel LIMIT $2",
      p, "read stream gaps");
  std::vector<StreamGap> out;
  for (int i = 0; i < s.Rows(); ++i) {
    out.push_back(StreamGap{stream_id, s.Int(i, 0), s.Int(i, 1), s.Int(i, 2), s.Int(i, 3),
                            s.Int(i, 4), s.Text(i, 5)});
  }
  return out;
}

}  // namespace km::server
