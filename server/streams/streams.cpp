#include "server/streams/streams.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "server/base/time_util.h"
#include "server/streams/stream_chunks.h"

namespace km::server {

StreamHub::StreamHub(StreamStore& storage, StreamOptions options)
    : storage_(storage), options_(options) {
  if (options_.chunk_samples == 0) options_.chunk_samples = 1;
  flusher_ = std::thread([this] { FlusherLoop(); });
}

StreamHub::~StreamHub() {
  {
    std::lock_guard lock(flusher_mu_);
    stopping_ = true;
  }
  flusher_cv_.notify_all();
  flusher_.join();
  try {
    FlushAll();
  } catch (...) {
    // Storage failing at shutdown: nothing more can be done here; the error was reported
    // by the flusher before.
  }
}

void StreamHub::FlusherLoop() {
  std::unique_lock lock(flusher_mu_);
  while (!stopping_) {
    flusher_cv_.wait_for(lock, std::chrono::milliseconds(options_.flush_interval_ms));
    if (stopping_) break;
    lock.unlock();
    try {
      FlushAll();
    } catch (...) {
      // Kept in memory (ready chunks stay queued) and retried on the next tick.
    }
    lock.lock();
  }
}

StreamId StreamHub::Create(const NewStream& stream) {
  const StreamId id = storage_.CreateStream(stream);
  Get(id);
  return id;
}

StreamHub::State& StreamHub::Get(StreamId stream_id) {
  State* state = nullptr;
  {
    std::lock_guard lock(mu_);
    auto it = states_.find(stream_id);
    if (it == states_.end()) {
      const auto rec = storage_.GetStream(stream_id);
      if (!rec) throw NotFound("stream " + to_string(stream_id) + " does not exist");
      it = states_.emplace(stream_id, std::make_unique<State>()).first;
      if (!rec->metadata_json.empty()) {
        const auto meta = ingest::ParseJsonTextOrDiscarded(rec->metadata_json);
        if (meta.is_object() && meta.contains("channels") && meta["channels"].is_array()) {
          for (const auto& c : meta["channels"]) {
            if (c.is_object() && c.contains("channel") && c["channel"].is_number_integer() &&
                c["channel"].get<std::int64_t>() >= 0) {
              it->second->declared.insert(c["channel"].get<std::uint32_t>());
            }
          }
        }
      }
    }
    state = it->second.get();
  }
  std::lock_guard lock(state->mu);
  if (!state->loaded) Load(stream_id, *state);
  return *state;
}

void StreamHub::Load(StreamId stream_id, State& s) {
  for (const auto& c : storage_.StreamChannels(stream_id)) {
    Channel& ch = s.channels[static_cast<std::uint32_t>(c.channel)];
    ch.counters = ingest::ChannelCounters(c.next_counter, c.last_t_us);
  }
  s.loaded = true;
}

void StreamHub::Seal(StreamId stream_id, Channel& ch, State& s) {
  auto& p = ch.pending;
  std::size_t begin = 0;
  while (begin < p.size()) {
    const std::size_t end = std::min(p.size(), begin + options_.chunk_samples);
    StreamChunk c = EncodeStreamChunk(p, begin, end);
    c.stream_id = stream_id;
    s.ready.push_back(std::move(c));
    begin = end;
  }
  p.t_us.clear();
  p.value_um.clear();
  p.status.clear();
}

void StreamHub::Write(State& s) {
  if (s.ready.empty() && s.gaps.empty()) return;
  storage_.AppendStream(s.ready, s.gaps);  // throws: both stay queued for the next attempt
  s.ready.clear();
  s.gaps.clear();
}

void StreamHub::Accept(StreamId stream_id, ingest::SampleRun run, IngestCounts& counts) {
  const std::size_t n = run.value_um.size();
  if (run.t_us.size() != n || (!run.status.empty() && run.status.size() != n)) {
    throw InvalidInput("", 0, "samples", "a run's timestamps, values and status differ in length");
  }
  if (run.status.empty()) run.status.assign(n, ingest::kStatusGood);
  ++counts.runs;
  counts.samples += n;
  if (n == 0) return;
  State& s = Get(stream_id);
  std::lock_guard lock(s.mu);
  if (!s.declared.empty() && !s.declared.count(run.channel)) {
    throw InvalidInput("", 0, "channel",
                       "channel " + std::to_string(run.channel) + " is not declared for stream " +
                           to_string(stream_id));
  }
  Channel& ch = s.channels[run.channel];
  ch.pending.channel = run.channel;
  const auto verdict = ch.counters.Take(run);
  const std::size_t skip = verdict.duplicates;
  counts.duplicates += skip;
  if (skip == n) return;
  const std::uint64_t first = run.first_counter + skip;
  if (verdict.gap) {
    StreamGap g;
    g.stream_id = stream_id;
    g.channel = run.channel;
    g.first_missing = static_cast<std::int64_t>(verdict.gap->first_missing);
    g.missing = static_cast<std::int64_t>(verdict.gap->missing);
    g.t_before_us = verdict.gap->t_before_us;
    g.t_after_us = verdict.gap->t_after_us;
    g.detected_at = NowUtcIso8601();
    s.gaps.push_back(g);
    counts.gaps.push_back(g);
    Seal(stream_id, ch, s);  // a chunk holds consecutive counters only
  }
  auto& p = ch.pending;
  if (p.size() == 0) p.first_counter = first;
  p.t_us.insert(p.t_us.end(), run.t_us.begin() + static_cast<std::ptrdiff_t>(skip), run.t_us.end());
  p.value_um.insert(p.value_um.end(), run.value_um.begin() + static_cast<std::ptrdiff_t>(skip),
                    run.value_um.end());
  p.status.insert(p.status.end(), run.status.begin() + static_cast<std::ptrdiff_t>(skip),
                  run.status.end());
  counts.accepted += n - skip;
  // Move whole chunks out of the pending buffer.
  if (p.size() >= options_.chunk_samples) {
    const std::size_t whole = p.size() / options_.chunk_samples * options_.chunk_samples;
    for (std::size_t b = 0; b < whole; b += options_.chunk_samples) {
      StreamChunk c = EncodeStreamChunk(p, b, b + options_.chunk_samples);
      c.stream_id = stream_id;
      s.ready.push_back(std::move(c));
    }
    const auto w = static_cast<std::ptrdiff_t>(whole);
    p.t_us.erase(p.t_us.begin(), p.t_us.begin() + w);
    p.value_um.erase(p.value_um.begin(), p.value_um.begin() + w);
    p.status.erase(p.status.begin(), p.status.begin() + w);
    p.first_counter += whole;
  }
  if (s.ready.size() >= options_.ready_chunks) Write(s);
}

void StreamHub::FlushLocked(StreamId stream_id, State& s) {
  for (auto& [id, ch] : s.channels) Seal(stream_id, ch, s);
  Write(s);
}

void StreamHub::Flush(StreamId stream_id) {
  State& s = Get(stream_id);
  std::lock_guard lock(s.mu);
  FlushLocked(stream_id, s);
}

void StreamHub::FlushAll() {
  std::vector<std::pair<StreamId, State*>> all;
  {
    std::lock_guard lock(mu_);
    for (auto& [id, st] : states_) all.emplace_back(id, st.get());
  }
  std::exception_ptr first_error;
  for (auto& [id, st] : all) {
    std::lock_guard lock(st->mu);
    try {
      FlushLocked(id, *st);
    } catch (...) {
      if (!first_error) first_error = std::current_exception();
    }
  }
  if (first_error) std::rethrow_exception(first_error);
}

std::map<std::uint32_t, std::size_t> StreamHub::Pending(StreamId stream_id) {
  State& s = Get(stream_id);
  std::lock_guard lock(s.mu);
  std::map<std::uint32_t, std::size_t> out;
  for (const auto& [id, ch] : s.channels) out[id] = ch.pending.size();
  for (const auto& c : s.ready) out[static_cast<std::uint32_t>(c.channel)] += c.n;
  return out;
}

namespace {
class HubSink final : public ingest::SampleSink {
 public:
  HubSink(StreamHub& hub, StreamId id) : hub_(hub), id_(id) {}
  void Deliver(const std::vector<ingest::StreamSample>& samples) override {
    IngestCounts counts;
    for (const auto& smp : samples) {
      ingest::SampleRun run;
      run.channel = smp.channel;
      run.first_counter = smp.counter;
      run.t_us.push_back(smp.t_us);
      run.value_um.push_back(smp.value_um);
      run.status.push_back(smp.status);
      hub_.Accept(id_, std::move(run), counts);
    }
  }

 private:
  StreamHub& hub_;
  StreamId id_;
};
}  // namespace

std::unique_ptr<ingest::SampleSink> StreamHub::SinkFor(StreamId stream_id) {
  Get(stream_id);  // NotFound now rather than in the acquisition thread
  return std::make_unique<HubSink>(*this, stream_id);
}

namespace {

// Min / max / sum / count per time bucket over [lo, hi] (both inclusive). Times enter as
// offsets from lo in unsigned 64-bit arithmetic, so that any two int64 time stamps (a span of
// up to 2^64 − 1 µs) are bucketed without overflow.
struct Buckets {
  std::int64_t lo = 0;
  std::uint64_t span = 0;  // hi − lo, exact
  double width = 1.0;      // (span + 1) / n µs
  std::vector<double> mn, mx, sum;
  std::vector<std::int64_t> cnt;
  Buckets(std::int64_t lo_us, std::int64_t hi_us, std::size_t n)
      : lo(lo_us),
        span(static_cast<std::uint64_t>(hi_us) - static_cast<std::uint64_t>(lo_us)),
        width((static_cast<double>(span) + 1.0) / static_cast<double>(n)),
        mn(n, std::numeric_limits<double>::infinity()),
        mx(n, -std::numeric_limits<double>::infinity()),
        sum(n, 0.0),
        cnt(n, 0) {}
  std::uint64_t Offset(std::int64_t t) const {
    return static_cast<std::uint64_t>(t) - static_cast<std::uint64_t>(lo);
  }
  std::size_t Of(std::int64_t t) const {
    const double q = static_cast<double>(Offset(t)) / width;
    const auto last = cnt.size() - 1;
    return q < static_cast<double>(last) ? static_cast<std::size_t>(q) : last;
  }
  // Middle of bucket k, rounded to the µs and kept within [lo, hi].
  std::int64_t Centre(std::size_t k) const {
    const double c = (static_cast<double>(k) + 0.5) * width;
    std::uint64_t off = span;
    if (c < 0x1p63) {
      off = static_cast<std::uint64_t>(std::llround(c));
    } else if (c < 0x1p64) {
      off = static_cast<std::uint64_t>(c);  // doubles this large are whole numbers
    }
    off = std::min(off, span);
    return static_cast<std::int64_t>(static_cast<std::uint64_t>(lo) + off);
  }
  void Add(std::size_t b, double vmin, double vmax, double vsum, std::int64_t n) {
    mn[b] = std::min(mn[b], vmin);
    mx[b] = std::max(mx[b], vmax);
    sum[b] += vsum;
    cnt[b] += n;
  }
};

}  // namespace

void ChannelSamples::AppendInRange(const ingest::SampleRun& run, std::int64_t from_us,
                                   std::int64_t to_us) {
  for (std::size_t i = 0; i < run.size(); ++i) {
    if (run.t_us[i] < from_us || run.t_us[i] >= to_us) continue;
    t_us.push_back(run.t_us[i]);
    counter.push_back(static_cast<std::int64_t>(run.first_counter + i));
    value_um.push_back(run.value_um[i]);
    status.push_back(run.status[i]);
  }
}

ChannelSamples ReadChannelSamples(StreamStore& storage, StreamId stream_id, std::int64_t channel,
                                  std::int64_t from_us, std::int64_t to_us) {
  ChannelSamples out;
  for (const auto& c : storage.ReadStreamChunks(stream_id, channel, from_us, to_us, true)) {
    out.AppendInRange(DecodeStreamChunk(c), from_us, to_us);
  }
  return out;
}

nlohmann::json StreamSamplesJson(StreamStore& storage, StreamId stream_id, std::int64_t channel,
                                 std::int64_t from_us, std::int64_t to_us, std::size_t max_points) {
  using nlohmann::json;
  if (!storage.GetStream(stream_id)) {
    throw NotFound("stream " + to_string(stream_id) + " does not exist");
  }
  if (to_us <= from_us) throw InvalidInput("", 0, "to_us", "must be later than from_us");
  if (max_points < 2) max_points = 2;
  json out = {{"stream_id", stream_id}, {"channel", channel}};
  const auto meta = storage.ReadStreamChunks(stream_id, channel, from_us, to_us, false);
  std::int64_t stored = 0;
  for (const auto& c : meta) stored += c.n;
  // Samples of one chunk inside [from_us, to_us).
  ChannelSamples loose;
  const auto take = [&](const StreamChunk& c) {
    StreamChunk with = c;
    with.data = storage.ReadStreamChunkData(stream_id, channel, c.first_counter);
    loose.AppendInRange(DecodeStreamChunk(with), from_us, to_us);
  };
  // Few samples: read them all. Many: chunks wholly inside the range that also fall in one
  // bucket enter with their stored statistics (exactly the min, max and sum of their samples);
  // only the others are decoded. The buckets are therefore the same as from every sample.
  constexpr std::int64_t kDecodeAll = 200000;
  const bool all =
      stored <= std::max<std::int64_t>(kDecodeAll, static_cast<std::int64_t>(max_points));
  std::vector<const StreamChunk*> whole;
  if (all) {
    loose = ReadChannelSamples(storage, stream_id, channel, from_us, to_us);
  } else {
    for (const auto& c : meta) {
      const bool inside = c.t_first_us >= from_us && c.t_last_us < to_us;
      if (inside) {
        whole.push_back(&c);
      } else {
        take(c);
      }
    }
  }
  std::int64_t in_range = static_cast<std::int64_t>(loose.t_us.size());
  for (const auto* c : whole) in_range += c->n;
  out["samples_in_range"] = in_range;
  if (in_range <= static_cast<std::int64_t>(max_points)) {
    if (!whole.empty()) {
      for (const auto* c : whole) take(*c);
      // Back into counter order (chunks were read in counter order, but in two groups).
      std::vector<std::size_t> order(loose.t_us.size());
      for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
      std::sort(order.begin(), order.end(),
                [&](std::size_t a, std::size_t b) { return loose.counter[a] < loose.counter[b]; });
      ChannelSamples sorted;
      for (const auto i : order) {
        sorted.t_us.push_back(loose.t_us[i]);
        sorted.counter.push_back(loose.counter[i]);
        sorted.value_um.push_back(loose.value_um[i]);
        sorted.status.push_back(loose.status[i]);
      }
      loose = std::move(sorted);
    }
    out["downsampled"] = false;
    out["t_us"] = loose.t_us;
    out["counter"] = loose.counter;
    out["value_um"] = loose.value_um;
    out["status"] = loose.status;
    return out;
  }
  // Buckets of equal time over the span actually covered, so a short burst is not squeezed.
  std::int64_t lo = std::numeric_limits<std::int64_t>::max();
  std::int64_t hi = std::numeric_limits<std::int64_t>::min();
  for (const auto t : loose.t_us) {
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  for (const auto* c : whole) {
    lo = std::min(lo, c->t_first_us);
    hi = std::max(hi, c->t_last_us);
  }
  Buckets b(lo, hi, max_points);
  for (const auto* c : whole) {
    const std::size_t b1 = b.Of(c->t_first_us), b2 = b.Of(c->t_last_us);
    if (b1 == b2) {
      b.Add(b1, c->value_min, c->value_max, c->value_sum, c->n);
    } else {
      take(*c);  // appended to loose, after the ones counted above
    }
  }
  for (std::size_t i = 0; i < loose.t_us.size(); ++i) {
    b.Add(b.Of(loose.t_us[i]), loose.value_um[i], loose.value_um[i], loose.value_um[i], 1);
  }
  json bt = json::array(), bmin = json::array(), bmax = json::array(), bmean = json::array(),
       bn = json::array();
  for (std::size_t k = 0; k < max_points; ++k) {
    if (b.cnt[k] == 0) continue;  // a gap or a quiet stretch: no bucket is invented
    bt.push_back(b.Centre(k));
    bmin.push_back(b.mn[k]);
    bmax.push_back(b.mx[k]);
    bmean.push_back(b.sum[k] / static_cast<double>(b.cnt[k]));
    bn.push_back(b.cnt[k]);
  }
  out["downsampled"] = true;
  out["bucket_us"] = b.width;
  out["t_us"] = bt;
  out["min_um"] = bmin;
  out["max_um"] = bmax;
  out["mean_um"] = bmean;
  out["count"] = bn;
  return out;
}

}  // namespace km::server
