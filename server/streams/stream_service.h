// Capacitance-sensor streams (docs/streams.md): streams created by a client or an acquisition
// device, frames received as the body arrives, the samples, gaps and channels read back, and a
// stretch of a channel turned into a stored straightness profile.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "server/measurements/measurement_service.h"
#include "server/storage/storage.h"
#include "server/streams/acquisition.h"
#include "server/streams/streams.h"

namespace km::server {

class StreamService {
 public:
  StreamService(StreamStore& store, MeasurementService& measurements);
  ~StreamService();  // stops the acquisition devices, then writes what the hub buffers
  StreamService(const StreamService&) = delete;
  StreamService& operator=(const StreamService&) = delete;

  // CreateStream: {"machine_id", "name"?, "channels"?: [{"channel", "name"?, "unit"?,
  // "rate_hz"?}], …} → the stream id. IngestFrames decodes frames as the body arrives (format
  // from the Content-Type), stores them and answers what was received, stored, dropped as
  // duplicate, and the gaps found. Samples of frames before a bad frame are kept; the bad frame
  // is reported (InvalidInput).
  using BodyReader = std::function<bool(const std::function<bool(std::string_view)>&)>;
  StreamId CreateStream(const nlohmann::json& request, const std::string& source = "http");
  nlohmann::json IngestFrames(StreamId stream_id, const std::string& content_type,
                              const BodyReader& read_body);
  nlohmann::json StreamJson(StreamId stream_id);
  nlohmann::json ListStreams(const std::optional<std::string>& machine_id, std::int64_t limit);
  nlohmann::json StreamGapsJson(StreamId stream_id, std::int64_t limit);
  nlohmann::json StreamSamples(StreamId stream_id, std::int64_t channel,
                               std::optional<std::int64_t> from_us,
                               std::optional<std::int64_t> to_us, std::size_t max_points);
  // Turns a stretch of one channel into a straightness profile (position from an encoder
  // channel or from feed × time), stores it as a kinemetric-straightness/1 measurement and
  // analyses it like an upload. Request: see docs/streams.md.
  UploadOutcome StreamProfile(StreamId stream_id, const nlohmann::json& request);

  StreamHub& hub() { return *hub_; }
  StreamStore& store() { return store_; }
  // Modbus TCP devices (server/streams/acquisition.h).
  Acquisition& acquisition() { return *acquisition_; }

 private:
  StreamStore& store_;
  MeasurementService& measurements_;
  std::unique_ptr<StreamHub> hub_;
  std::unique_ptr<Acquisition> acquisition_;  // after hub_: stopped before it
};

// One body of stream frames being received: Feed stores every complete frame as it arrives;
// Finish answers what was received (frames, samples, stored, duplicates, gaps). Samples of
// frames before a bad frame are kept; the bad frame is reported (InvalidInput). Used by the
// HTTP layer, which feeds pieces as they come off the socket.
class FrameIngestion {
 public:
  // Throws NotFound when the stream does not exist.
  FrameIngestion(StreamService& streams, StreamId stream_id, const std::string& content_type);
  ~FrameIngestion();
  void Feed(std::string_view piece);
  // complete = false: the body ended early; what was stored stays, InvalidInput says so.
  nlohmann::json Finish(bool complete);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace km::server
