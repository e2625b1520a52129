// Endpoints of the capacitance-sensor streams (docs/streams.md): open a stream, send frames
// (the body is decoded and stored as it arrives), read samples for plots, gaps, and turn a
// stretch into a straightness profile; and of the Modbus TCP acquisition devices
// (api/endpoints.h).
#include <limits>

#include "api/endpoints.h"
#include "api/route_util.h"

namespace km::api::endpoints {
namespace {

json PathParam(const std::string& description) {
  return {{"name", "id"},
          {"in", "path"},
          {"required", true},
          {"description", description},
          {"schema", {{"type", "integer"}}}};
}
constexpr std::int64_t kMaxI64 = std::numeric_limits<std::int64_t>::max();
constexpr std::int64_t kMinI64 = std::numeric_limits<std::int64_t>::min();

using server::FrameIngestion;

// Frames stored as the body arrives.
class FrameSink : public BodySink {
 public:
  FrameSink(server::Service& svc, server::StreamId id, const std::string& content_type)
      : ingestion_(svc.streams(), id, content_type) {}
  void Feed(std::string_view piece) override { ingestion_.Feed(piece); }
  Response Finish(bool complete) override { return Response::Json(ingestion_.Finish(complete)); }

 private:
  FrameIngestion ingestion_;
};

}  // namespace

Endpoint CreateStream(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Open a capacitance-sensor stream (machine, channels)",
      [svc](const Request& req) {
        const auto id = svc->streams().CreateStream(JsonBody(req));
        Response r = Response::Json(svc->streams().StreamJson(id), 201);
        r.headers["Location"] = "/api/v1/streams/" + to_string(id);
        return r;
      },
      {{"requestBody",
        JsonRequestBody({{"type", "object"},
                         {"required", json::array({"machine_id"})},
                         {"properties",
                          {{"machine_id", {{"type", "string"}}},
                           {"name", {{"type", "string"}}},
                           {"channels", {{"type", "array"}, {"items", {{"type", "object"}}}}}}}})},
       {"responses", {{"201", JsonResponse("the stream {id, channels[], …}")}}}},
      kSmallRequestBytes};
}

Endpoint SendFrames(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Send stream frames (binary application/vnd.kinemetric.stream-frame or "
      "application/x-ndjson); the body may be long and chunked: frames are stored as they "
      "arrive, the answer comes when the body ends",
      [svc](const Request& req) {
        // Callers that hold the whole body (tests, tools); the HTTP server uses open_body.
        FrameIngestion ingestion(svc->streams(), req.PathId<server::StreamId>("id"),
                                 req.Header("content-type").value_or(""));
        ingestion.Feed(req.body);
        return Response::Json(ingestion.Finish(true));
      },
      {{"parameters", json::array({PathParam("stream id")})},
       {"requestBody",
        {{"required", true},
         {"content",
          {{"application/vnd.kinemetric.stream-frame",
            {{"schema", {{"type", "string"}, {"format", "binary"}}}}},
           {"application/x-ndjson", {{"schema", {{"type", "string"}}}}}}}}},
       {"responses", {{"200", JsonResponse("{frames, samples, stored, duplicates, gaps[]}")}}}},
      0,
      [svc](const Request& req) -> std::unique_ptr<BodySink> {
        return std::make_unique<FrameSink>(*svc, req.PathId<server::StreamId>("id"),
                                           req.Header("content-type").value_or(""));
      }};
}

Endpoint ListStreams(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Streams (newest first), with per-channel sample and gap counts",
          [svc](const Request& req) {
            return Response::Json(svc->streams().ListStreams(req.Query("machine_id"),
                                                             QueryInt(req, "limit", 50, 1, 1000)));
          },
          {{"parameters", json::array({Param("machine_id", "string", "only this machine"),
                                       Param("limit", "integer", "1 to 1000")})},
           {"responses", {{"200", JsonResponse("{items[]}")}}}}};
}

Endpoint GetStream(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"One stream: channels, samples, gaps, buffered samples",
          [svc](const Request& req) {
            return Response::Json(svc->streams().StreamJson(req.PathId<server::StreamId>("id")));
          },
          {{"parameters", json::array({PathParam("stream id")})},
           {"responses", {{"200", JsonResponse("the stream")}}}}};
}

Endpoint StreamSamples(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Samples of one channel in a time range; min/max/mean buckets when there are more "
      "than max_points",
      [svc](const Request& req) {
        std::optional<std::int64_t> from, to;
        if (req.Query("from_us")) from = QueryInt(req, "from_us", 0, kMinI64, kMaxI64);
        if (req.Query("to_us")) to = QueryInt(req, "to_us", 0, kMinI64, kMaxI64);
        return Response::Json(svc->streams().StreamSamples(
            req.PathId<server::StreamId>("id"), QueryInt(req, "channel", 0, 0, 65535), from, to,
            static_cast<std::size_t>(QueryInt(req, "max_points", 2000, 2, 1000000))));
      },
      {{"parameters",
        json::array({PathParam("stream id"), Param("channel", "integer", "channel id"),
                     Param("from_us", "integer", "µs since the epoch, inclusive"),
                     Param("to_us", "integer", "µs since the epoch, exclusive"),
                     Param("max_points", "integer", "2 to 1000000 (default 2000)")})},
       {"responses",
        {{"200", JsonResponse("{downsampled, t_us[], value_um[] | min_um[], max_um[], "
                              "mean_um[], count[]}")}}}}};
}

Endpoint StreamGaps(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Recorded gaps (counter jumps) of a stream",
          [svc](const Request& req) {
            return Response::Json(svc->streams().StreamGapsJson(
                req.PathId<server::StreamId>("id"), QueryInt(req, "limit", 1000, 1, 100000)));
          },
          {{"parameters", json::array({PathParam("stream id")})},
           {"responses", {{"200", JsonResponse("{items[]}")}}}}};
}

Endpoint StreamProfile(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Turn a stretch of one channel into a straightness profile, stored and analysed as a "
      "measurement",
      [svc](const Request& req) {
        const auto out =
            svc->streams().StreamProfile(req.PathId<server::StreamId>("id"), JsonBody(req));
        return Response::Json({{"id", out.id},
                               {"created", out.created},
                               {"kind", out.kind},
                               {"results", svc->measurements().Results(out.id)}},
                              out.created ? 201 : 200);
      },
      {{"parameters", json::array({PathParam("stream id")})},
       {"requestBody",
        {{"required", true},
         {"content",
          {{"application/json",
            {{"schema",
              {{"type", "object"},
               {"required", json::array({"channel", "axis", "error_direction", "position"})},
               {"properties",
                {{"channel", {{"type", "integer"}}},
                 {"from_us", {{"type", "integer"}}},
                 {"to_us", {{"type", "integer"}}},
                 {"axis", {{"type", "string"}}},
                 {"error_direction", {{"type", "string"}}},
                 {"points", {{"type", "integer"}}},
                 {"position", {{"type", "object"}}}}}}}}}}}}},
       {"responses", {{"201", JsonResponse("{id, results} of the new straightness measurement")}}}},
      kSmallRequestBytes};
}

Endpoint ListDevices(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Modbus TCP devices: configuration, stream, status (connected, last sample, "
      "error counts)",
      [svc](const Request&) {
        return Response::Json({{"items", svc->streams().acquisition().Devices()}});
      },
      {{"responses", {{"200", JsonResponse("{items[]}")}}}}};
}

Endpoint AddDevice(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {
      "Start acquiring from a Modbus TCP device (docs/modbus.md, plus machine_id); "
      "runs until the server stops",
      [svc](const Request& req) {
        return Response::Json(svc->streams().acquisition().Add(JsonBody(req)), 201);
      },
      {{"requestBody", JsonRequestBody({{"type", "object"}})},
       {"responses", {{"201", JsonResponse("the device entry")}}}},
      kSmallRequestBytes};
}

Endpoint RemoveDevice(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"Stop acquiring from a device (its stream and samples stay)",
          [svc](const Request& req) {
            const std::string name = req.path_params.at("name");
            svc->streams().acquisition().Remove(name);
            return Response::Json({{"stopped", name}});
          },
          {{"responses", {{"200", JsonResponse("{stopped}")}}}}};
}

}  // namespace km::api::endpoints
