// Counter bookkeeping of one stream channel (docs/formats.md §1.6): which samples of an arriving
// run are new, and whether counters were skipped (a gap). Shared by the server's stream storage and
// the offline `kinemetric stream` commands so both judge gaps and duplicates the same way.
//
//   run.first_counter == next → all new;
//   run.first_counter  > next → counters next … first−1 never arrived: a gap;
//   run.first_counter  < next → the first (next − first) samples were seen before: duplicates.
#pragma once

#include <cstdint>
#include <optional>

#include "ingest/stream/stream_record.h"

namespace km::ingest {

struct CounterGap {
  std::uint64_t first_missing = 0;
  std::uint64_t missing = 0;
  std::int64_t t_before_us = 0;  // last sample before the gap
  std::int64_t t_after_us = 0;   // first sample after it
};

struct CounterVerdict {
  std::size_t duplicates = 0;  // leading samples of the run to drop
  std::optional<CounterGap> gap;
};

class ChannelCounters {
 public:
  ChannelCounters() = default;
  // Resumes after stored samples: `next` is one past the highest stored counter.
  ChannelCounters(std::uint64_t next, std::int64_t last_t_us)
      : known_(true), next_(next), last_t_us_(last_t_us) {}

  // Judges a run (t_us.size() == value_um.size()) and advances past it. The first run of a
  // channel that has no history defines where counting starts (no gap before it).
  CounterVerdict Take(const SampleRun& run) {
    CounterVerdict v;
    const std::size_t n = run.value_um.size();
    if (n == 0) return v;
    if (!known_) {
      known_ = true;
      next_ = run.first_counter;
    }
    if (run.first_counter < next_) {
      const std::uint64_t behind = next_ - run.first_counter;
      v.duplicates = behind >= n ? n : static_cast<std::size_t>(behind);
      if (v.duplicates == n) return v;
    }
    const std::uint64_t first = run.first_counter + v.duplicates;
    if (first > next_) {
      v.gap = CounterGap{next_, first - next_, last_t_us_, run.t_us[v.duplicates]};
    }
    next_ = first + (n - v.duplicates);
    last_t_us_ = run.t_us.back();
    return v;
  }

  bool known() const { return known_; }
  std::uint64_t next() const { return next_; }

 private:
  bool known_ = false;
  std::uint64_t next_ = 0;
  std::int64_t last_t_us_ = 0;
};

}  // namespace km::ingest
