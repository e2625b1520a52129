// Capacitance-sensor streams in the server: where HTTP stream frames and Modbus polls arrive.
//
// Every arriving run of samples (ingest/stream/stream_record.h) is checked against the channel's
// next expected counter:
//   counter == next  → appended;
//   counter  > next  → the counters in between never arrived: a gap {first_missing, missing,
//                      t_before_us, t_after_us} is recorded, then the run is appended;
//   counter  < next  → those samples were received before (a client resending after an error,
//                      or a late frame for a recorded gap): counted as duplicates and dropped,
//                      so resending is always safe.
// Samples are buffered per channel and written in chunks of consecutive counters
// (server/streams/stream_chunks.h) of at most `chunk_samples`; Flush() writes what is buffered, and
// an HTTP request is answered only after its samples are stored. The next expected counter of a
// channel survives a restart (it is read back from the stored chunks).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/stream/stream_counters.h"
#include "ingest/stream/stream_record.h"
#include "server/storage/storage.h"

namespace km::server {

struct StreamOptions {
  std::size_t chunk_samples = 4096;  // samples per stored chunk (at most)
  std::size_t ready_chunks = 32;     // full chunks kept before they are written
  int flush_interval_ms = 1000;      // background flush of partial chunks (Modbus devices)
};

struct IngestCounts {
  std::uint64_t runs = 0;
  std::uint64_t samples = 0;     // received
  std::uint64_t accepted = 0;    // new, stored
  std::uint64_t duplicates = 0;  // received before (dropped)
  std::vector<StreamGap> gaps;   // found while ingesting
};

class StreamHub {
 public:
  StreamHub(StreamStore& storage, StreamOptions options);
  ~StreamHub();  // stops the background flusher and writes what is buffered
  StreamHub(const StreamHub&) = delete;
  StreamHub& operator=(const StreamHub&) = delete;

  // Stores a new stream. Channels declared in its metadata ({"channels": [{"channel": N}, …]})
  // are the only ones accepted; without a declaration any channel is.
  StreamId Create(const NewStream& stream);

  // Thread-safe. Throws NotFound for an unknown stream, InvalidInput for an undeclared channel
  // or a malformed run.
  void Accept(StreamId stream_id, ingest::SampleRun run, IngestCounts& counts);
  void Flush(StreamId stream_id);
  void FlushAll();

  // Buffered (not yet written) samples of a stream, per channel.
  std::map<std::uint32_t, std::size_t> Pending(StreamId stream_id);

  // A sink for an acquisition thread (e.g. a Modbus device) that feeds one stream. The hub's
  // background flusher writes its samples at least every flush_interval_ms.
  std::unique_ptr<ingest::SampleSink> SinkFor(StreamId stream_id);

 private:
  struct Channel {
    ingest::ChannelCounters counters;
    ingest::SampleRun pending;
  };
  struct State {
    std::mutex mu;
    bool loaded = false;
    std::set<std::uint32_t> declared;
    std::map<std::uint32_t, Channel> channels;
    std::vector<StreamChunk> ready;
    std::vector<StreamGap> gaps;
  };
  State& Get(StreamId stream_id);
  void Load(StreamId stream_id, State& s);
  void Seal(StreamId stream_id, Channel& ch, State& s);  // pending → ready (partial chunk)
  void Write(State& s);                                  // ready + gaps → storage
  void FlushLocked(StreamId stream_id, State& s);
  void FlusherLoop();

  StreamStore& storage_;
  StreamOptions options_;
  std::mutex mu_;
  std::map<StreamId, std::unique_ptr<State>> states_;
  std::mutex flusher_mu_;
  std::condition_variable flusher_cv_;
  bool stopping_ = false;
  std::thread flusher_;
};

// Stored samples of one channel with from_us ≤ t_us < to_us, in counter order.
struct ChannelSamples {
  std::vector<std::int64_t> t_us, counter;
  std::vector<double> value_um;
  std::vector<std::uint8_t> status;
  std::size_t size() const { return t_us.size(); }
  // Appends the samples of a decoded chunk that fall in [from_us, to_us).
  void AppendInRange(const ingest::SampleRun& run, std::int64_t from_us, std::int64_t to_us);
};
ChannelSamples ReadChannelSamples(StreamStore& storage, StreamId stream_id, std::int64_t channel,
                                  std::int64_t from_us, std::int64_t to_us);

// Samples of one channel in [from_us, to_us) for plots: the samples themselves when there are
// at most max_points, else max_points time buckets with min, max, mean and count.
nlohmann::json StreamSamplesJson(StreamStore& storage, StreamId stream_id, std::int64_t channel,
                                 std::int64_t from_us, std::int64_t to_us, std::size_t max_points);

}  // namespace km::server
