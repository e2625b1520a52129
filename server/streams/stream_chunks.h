// Compact encoding of one stream chunk (consecutive samples of one channel) as stored:
//
//   byte 0      version (1)
//   byte 1      flags: bit0 = per-sample status bytes follow the values
//   varint      n
//   varint      zig-zag(t_0), then zig-zag(t_k − t_{k−1}) for k = 1 … n−1  (µs; uniform rates
//               cost one or two bytes a sample)
//   n × f64     value_um, little-endian IEEE 754 (exact: the value as received)
//   n × u8      status (only when bit0)
//
// Counters are not stored per sample: a chunk holds first_counter … first_counter + n − 1.
#pragma once

#include <cstddef>
#include <string>

#include "ingest/stream/stream_record.h"
#include "server/storage/storage.h"

namespace km::server {

// Encodes samples [begin, end) of the run; fills the chunk's statistics. stream_id is the
// caller's to set. first_counter = run.first_counter + begin.
StreamChunk EncodeStreamChunk(const ingest::SampleRun& run, std::size_t begin, std::size_t end);

// Decodes a stored chunk (throws km::Error when the blob is damaged).
ingest::SampleRun DecodeStreamChunk(const StreamChunk& chunk);

}  // namespace km::server
