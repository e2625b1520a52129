// Service calls of the capacitance-sensor streams (docs/streams.md).
#include <cmath>
#include <cstdio>
#include <limits>

#include "analysis/core/errors.h"
#include "ingest/json_text.h"
#include "ingest/stream/stream_frames.h"
#include "server/base/request_json.h"
#include "server/base/time_util.h"
#include "server/streams/stream_chunks.h"
#include "server/streams/stream_service.h"
#include "usecases/stream_profile.h"

namespace km::server {
namespace {

using nlohmann::json;

namespace req = km::server::request;
using req::OptionalString;
using req::RequiredString;

void CheckMachineId(const std::string& id, const std::string& field) {
  for (char c : id) {
    const bool ok =
        std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == ':';
    if (!ok) {
      throw InvalidInput(req::kFile, 0, field,
                         "'" + id + "' may only hold letters, digits and - _ . :");
    }
  }
}

json GapJson(const StreamGap& g) {
  return {{"channel", g.channel},       {"first_missing", g.first_missing},
          {"missing", g.missing},       {"t_before_us", g.t_before_us},
          {"t_after_us", g.t_after_us}, {"detected_at", g.detected_at}};
}

// All samples of a channel in [from, to), in counter order, as one run.
ingest::SampleRun ReadChannel(StreamStore& storage, StreamId stream, std::int64_t channel,
                              std::int64_t from_us, std::int64_t to_us) {
  auto samples = ReadChannelSamples(storage, stream, channel, from_us, to_us);
  ingest::SampleRun out;
  out.channel = static_cast<std::uint32_t>(channel);
  out.t_us = std::move(samples.t_us);
  out.value_um = std::move(samples.value_um);
  out.status = std::move(samples.status);
  return out;
}

}  // namespace

StreamService::StreamService(StreamStore& store, MeasurementService& measurements)
    : store_(store),
      measurements_(measurements),
      hub_(std::make_unique<StreamHub>(store, StreamOptions{})),
      acquisition_(std::make_unique<Acquisition>(
          *hub_, [this](const json& request, const std::string& source) {
            return CreateStream(request, source);
          })) {}

StreamService::~StreamService() {
  acquisition_.reset();  // the devices stop before the hub writes what it buffers
}

StreamId StreamService::CreateStream(const json& request, const std::string& source) {
  if (!request.is_object()) throw InvalidInput(req::kFile, 0, "", "a JSON object is required");
  NewStream s;
  s.machine_id = RequiredString(request, "machine_id");
  CheckMachineId(s.machine_id, "machine_id");
  s.name = OptionalString(request, "name", "");
  s.source = source;
  std::set<std::uint32_t> declared;
  if (request.contains("channels")) {
    const auto& chans = request["channels"];
    if (!chans.is_array()) throw InvalidInput(req::kFile, 0, "channels", "must be an array");
    for (std::size_t i = 0; i < chans.size(); ++i) {
      const std::string field = "channels[" + std::to_string(i) + "]";
      if (!chans[i].is_object()) throw InvalidInput(req::kFile, 0, field, "must be an object");
      const auto& c = chans[i];
      if (!c.contains("channel") || !c["channel"].is_number_integer() ||
          c["channel"].get<std::int64_t>() < 0 || c["channel"].get<std::int64_t>() > 65535) {
        throw InvalidInput(req::kFile, 0, field + ".channel", "a whole number 0…65535 is required");
      }
      if (!declared.insert(c["channel"].get<std::uint32_t>()).second) {
        throw InvalidInput(req::kFile, 0, field + ".channel", "the channel is declared twice");
      }
      if (c.contains("rate_hz") &&
          (!c["rate_hz"].is_number() || !(c["rate_hz"].get<double>() > 0))) {
        throw InvalidInput(req::kFile, 0, field + ".rate_hz", "must be a positive number");
      }
    }
  }
  s.metadata_json = request.dump();
  return hub_->Create(s);
}

struct FrameIngestion::State {
  StreamHub& hub;
  StreamId stream_id;
  std::string source;
  ingest::StreamFrameDecoder decoder;
  IngestCounts counts;
  bool finished = false;
  void OnRun(ingest::SampleRun&& run) { hub.Accept(stream_id, std::move(run), counts); }
};

FrameIngestion::FrameIngestion(StreamService& streams, StreamId stream_id,
                               const std::string& content_type) {
  if (!streams.store().GetStream(stream_id)) {
    throw NotFound("stream " + to_string(stream_id) + " does not exist");
  }
  const std::string source = "stream " + to_string(stream_id) + " frames";
  state_.reset(new State{
      streams.hub(),
      stream_id,
      source,
      ingest::StreamFrameDecoder(ingest::FrameFormatFromContentType(content_type), source),
      {}});
}

FrameIngestion::~FrameIngestion() {
  if (state_ && !state_->finished) {
    try {
      state_->hub.Flush(state_->stream_id);
    } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw
    }
  }
}

void FrameIngestion::Feed(std::string_view piece) {
  auto& s = *state_;
  try {
    s.decoder.Feed(piece, [&s](ingest::SampleRun&& run) { s.OnRun(std::move(run)); });
  } catch (...) {
    s.finished = true;
    s.hub.Flush(s.stream_id);  // every frame before the bad one is kept
    throw;
  }
}

json FrameIngestion::Finish(bool complete) {
  auto& s = *state_;
  s.finished = true;
  try {
    if (complete) s.decoder.Finish([&s](ingest::SampleRun&& run) { s.OnRun(std::move(run)); });
  } catch (...) {
    s.hub.Flush(s.stream_id);
    throw;
  }
  s.hub.Flush(s.stream_id);
  if (!complete) {
    throw InvalidInput(s.source, 0, "body",
                       "the connection ended before the body was complete; the " +
                           std::to_string(s.decoder.frames()) +
                           " complete frames were stored, resend from the next counter");
  }
  json gaps = json::array();
  for (const auto& g : s.counts.gaps) gaps.push_back(GapJson(g));
  return {{"stream_id", s.stream_id},          {"frames", s.decoder.frames()},
          {"samples", s.counts.samples},       {"stored", s.counts.accepted},
          {"duplicates", s.counts.duplicates}, {"gaps", gaps}};
}

json StreamService::IngestFrames(StreamId stream_id, const std::string& content_type,
                                 const BodyReader& read_body) {
  FrameIngestion ingestion(*this, stream_id, content_type);
  const bool complete = read_body([&ingestion](std::string_view piece) {
    ingestion.Feed(piece);
    return true;
  });
  return ingestion.Finish(complete);
}

json StreamService::StreamJson(StreamId stream_id) {
  const auto rec = store_.GetStream(stream_id);
  if (!rec) throw NotFound("stream " + to_string(stream_id) + " does not exist");
  json j;
  j["id"] = rec->id;
  j["machine_id"] = rec->machine_id;
  j["name"] = rec->name;
  j["source"] = rec->source;
  j["created_at"] = rec->created_at;
  j["metadata"] = ingest::ParseJsonTextOrDiscarded(rec->metadata_json);
  const auto pending = hub_->Pending(stream_id);
  json chans = json::array();
  std::int64_t total = 0, gaps = 0;
  // Each channel's missing count fits 63 bits (its gaps lie within 0 … 2⁶³ − 1); their sum over
  // channels may not, so it is kept unsigned and, past 2⁶⁴ − 1, given as a double.
  std::uint64_t missing = 0;
  bool missing_beyond_u64 = false;
  double missing_approx = 0.0;
  for (const auto& c : store_.StreamChannels(stream_id)) {
    const auto p = pending.find(static_cast<std::uint32_t>(c.channel));
    chans.push_back({{"channel", c.channel},
                     {"samples", c.samples},
                     {"chunks", c.chunks},
                     {"flagged", c.flagged},
                     {"first_t_us", c.first_t_us},
                     {"last_t_us", c.last_t_us},
                     {"next_counter", c.next_counter},
                     {"gaps", c.gaps},
                     {"missing", c.missing},
                     {"buffered", p == pending.end() ? 0 : p->second}});
    total += c.samples;
    gaps += c.gaps;
    missing_beyond_u64 |=
        __builtin_add_overflow(missing, static_cast<std::uint64_t>(c.missing), &missing);
    missing_approx += static_cast<double>(c.missing);
  }
  j["channels"] = chans;
  j["samples"] = total;
  j["gap_count"] = gaps;
  j["missing"] = missing_beyond_u64 ? json(missing_approx) : json(missing);
  return j;
}

json StreamService::ListStreams(const std::optional<std::string>& machine_id, std::int64_t limit) {
  json items = json::array();
  for (const auto& s : store_.ListStreams(machine_id, limit)) items.push_back(StreamJson(s.id));
  return {{"items", items}};
}

json StreamService::StreamGapsJson(StreamId stream_id, std::int64_t limit) {
  if (!store_.GetStream(stream_id)) {
    throw NotFound("stream " + to_string(stream_id) + " does not exist");
  }
  json items = json::array();
  for (const auto& g : store_.StreamGaps(stream_id, limit)) items.push_back(GapJson(g));
  return {{"stream_id", stream_id}, {"items", items}};
}

json StreamService::StreamSamples(StreamId stream_id, std::int64_t channel,
                                  std::optional<std::int64_t> from_us,
                                  std::optional<std::int64_t> to_us, std::size_t max_points) {
  std::int64_t lo = std::numeric_limits<std::int64_t>::min();
  std::int64_t hi = std::numeric_limits<std::int64_t>::max();
  return StreamSamplesJson(store_, stream_id, channel, from_us.value_or(lo), to_us.value_or(hi),
                           max_points);
}

UploadOutcome StreamService::StreamProfile(StreamId stream_id, const json& request) {
  const auto rec = store_.GetStream(stream_id);
  if (!rec) throw NotFound("stream " + to_string(stream_id) + " does not exist");
  if (!request.is_object()) throw InvalidInput(req::kFile, 0, "", "a JSON object is required");
  const auto channel = req::WholeNumber(request, "channel", 0, 65535);
  const auto from_us = req::WholeNumber(
      request, "from_us", std::numeric_limits<std::int64_t>::min(),
      std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::min());
  const auto to_us = req::WholeNumber(request, "to_us", std::numeric_limits<std::int64_t>::min(),
                                      std::numeric_limits<std::int64_t>::max(),
                                      std::numeric_limits<std::int64_t>::max());
  const std::string axis = RequiredString(request, "axis");
  const std::string error_direction = RequiredString(request, "error_direction");
  const auto bins = static_cast<std::size_t>(req::WholeNumber(request, "points", 3, 100000, 1000));
  hub_->Flush(stream_id);  // a profile sees every sample received so far
  const auto sensor = ReadChannel(store_, stream_id, channel, from_us, to_us);
  if (!request.contains("position") || !request["position"].is_object()) {
    throw InvalidInput(req::kFile, 0, "position",
                       "an object {\"encoder_channel\": N} or {\"feed_mm_min\": F, "
                       "\"start_mm\": X} is required");
  }
  const auto& pos = request["position"];
  usecases::ProfileSpec spec;
  spec.machine_id = rec->machine_id;
  spec.axis = axis;
  spec.error_direction = error_direction;
  spec.sensor = OptionalString(request, "sensor", spec.sensor);
  spec.reference = OptionalString(request, "reference", spec.reference);
  spec.test_id = OptionalString(request, "test_id", "");
  spec.points = bins;
  spec.provenance = {{"source_stream", to_string(stream_id)}};
  std::optional<ingest::SampleRun> encoder;
  if (pos.contains("encoder_channel")) {
    const auto enc = req::WholeNumber(pos, "encoder_channel", 0, 65535);
    encoder = ReadChannel(store_, stream_id, enc, from_us, to_us);
  } else {
    spec.feed_mm_min = req::Number(pos, "feed_mm_min", std::nullopt);
    spec.start_mm = req::Number(pos, "start_mm", 0.0);
  }
  const std::string text =
      usecases::StraightnessFileFromStream(spec, sensor, encoder ? &*encoder : nullptr);
  return measurements_.Upload(
      text, "stream-" + to_string(stream_id) + "-ch" + std::to_string(channel) + ".csv");
}

}  // namespace km::server
