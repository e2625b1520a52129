// Routes of the capacitance-sensor streams (docs/streams.md): create a stream, send frames
// (the body is decoded and stored as it arrives), read samples for plots, gaps, and turn a
// stretch into a straightness profile.
#include <limits>

#include "api/route_util.h"
#include "api/routes.h"

namespace km::api {

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
  FrameSink(server::Service& svc, std::int64_t id, const std::string& content_type)
      : ingestion_(svc.streams(), id, content_type) {}
  void Feed(std::string_view piece) override { ingestion_.Feed(piece); }
  Response Finish(bool complete) override { return Response::Json(ingestion_.Finish(complete)); }

 private:
  FrameIngestion ingestion_;
};

// Reading a stream: list, one, samples for plots, gaps; a stretch turned into a profile.
void AddStreamReadRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(Route{"GET",
                   "/api/v1/streams",
                   "Streams (newest first), with per-channel sample and gap counts",
                   true,
                   [svc](const Request& req) {
                     return Response::Json(svc->streams().ListStreams(
                         req.Query("machine_id"), QueryInt(req, "limit", 50, 1, 1000)));
                   },
                   {{"parameters", json::array({Param("machine_id", "string", "only this machine"),
                                                Param("limit", "integer", "1 to 1000")})},
                    {"responses", {{"200", JsonResponse("{items[]}")}}}}});

  router.Add(Route{"GET",
                   "/api/v1/streams/{id}",
                   "One stream: channels, samples, gaps, buffered samples",
                   true,
                   [svc](const Request& req) {
                     return Response::Json(svc->streams().StreamJson(req.PathId("id")));
                   },
                   {{"parameters", json::array({PathParam("stream id")})},
                    {"responses", {{"200", JsonResponse("the stream")}}}}});

  router.Add(
      Route{"GET",
            "/api/v1/streams/{id}/samples",
            "Samples of one channel in a time range; min/max/mean buckets when there are more "
            "than max_points",
            true,
            [svc](const Request& req) {
              std::optional<std::int64_t> from, to;
              if (req.Query("from_us")) from = QueryInt(req, "from_us", 0, kMinI64, kMaxI64);
              if (req.Query("to_us")) to = QueryInt(req, "to_us", 0, kMinI64, kMaxI64);
              return Response::Json(svc->streams().StreamSamples(
                  req.PathId("id"), QueryInt(req, "channel", 0, 0, 65535), from, to,
                  static_cast<std::size_t>(QueryInt(req, "max_points", 2000, 2, 1000000))));
            },
            {{"parameters",
              json::array({PathParam("stream id"), Param("channel", "integer", "channel id"),
                           Param("from_us", "integer", "µs since the epoch, inclusive"),
                           Param("to_us", "integer", "µs since the epoch, exclusive"),
                           Param("max_points", "integer", "2 to 1000000 (default 2000)")})},
             {"responses",
              {{"200", JsonResponse("{downsampled, t_us[], value_um[] | min_um[], max_um[], "
                                    "mean_um[], count[]}")}}}}});

  router.Add(Route{"GET",
                   "/api/v1/streams/{id}/gaps",
                   "Recorded gaps (counter jumps) of a stream",
                   true,
                   [svc](const Request& req) {
                     return Response::Json(svc->streams().StreamGapsJson(
                         req.PathId("id"), QueryInt(req, "limit", 1000, 1, 100000)));
                   },
                   {{"parameters", json::array({PathParam("stream id")})},
                    {"responses", {{"200", JsonResponse("{items[]}")}}}}});

  router.Add(WithBodyLimit(
      Route{"POST",
            "/api/v1/streams/{id}/profile",
            "Turn a stretch of one channel into a straightness profile, stored and analysed as a "
            "measurement",
            true,
            [svc](const Request& req) {
              const auto out = svc->streams().StreamProfile(req.PathId("id"), JsonBody(req));
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
             {"responses",
              {{"201", JsonResponse("{id, results} of the new straightness measurement")}}}}},
      kSmallRequestBytes));
}

// The Modbus TCP acquisition devices (server/streams/acquisition.h).
void AddDeviceRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(Route{"GET",
                   "/api/v1/devices",
                   "Modbus TCP devices: configuration, stream, status (connected, last sample, "
                   "error counts)",
                   true,
                   [svc](const Request&) {
                     return Response::Json({{"items", svc->streams().acquisition().Devices()}});
                   },
                   {{"responses", {{"200", JsonResponse("{items[]}")}}}}});

  router.Add(WithBodyLimit(
      Route{"POST",
            "/api/v1/devices",
            "Start acquiring from a Modbus TCP device (docs/modbus.md, plus machine_id); "
            "runs until the server stops",
            true,
            [svc](const Request& req) {
              return Response::Json(svc->streams().acquisition().Add(JsonBody(req)), 201);
            },
            {{"requestBody", JsonRequestBody({{"type", "object"}})},
             {"responses", {{"201", JsonResponse("the device entry")}}}}},
      kSmallRequestBytes));

  router.Add(Route{"DELETE",
                   "/api/v1/devices/{name}",
                   "Stop acquiring from a device (its stream and samples stay)",
                   true,
                   [svc](const Request& req) {
                     const std::string name = req.path_params.at("name");
                     svc->streams().acquisition().Remove(name);
                     return Response::Json({{"stopped", name}});
                   },
                   {{"responses", {{"200", JsonResponse("{stopped}")}}}}});
}
}  // namespace

void AddStreamRoutes(Router& router, server::Service& service) {
  server::Service* svc = &service;

  router.Add(WithBodyLimit(
      Route{"POST",
            "/api/v1/streams",
            "Open a capacitance-sensor stream (machine, channels)",
            true,
            [svc](const Request& req) {
              const auto id = svc->streams().CreateStream(JsonBody(req));
              Response r = Response::Json(svc->streams().StreamJson(id), 201);
              r.headers["Location"] = "/api/v1/streams/" + std::to_string(id);
              return r;
            },
            {{"requestBody",
              JsonRequestBody(
                  {{"type", "object"},
                   {"required", json::array({"machine_id"})},
                   {"properties",
                    {{"machine_id", {{"type", "string"}}},
                     {"name", {{"type", "string"}}},
                     {"channels", {{"type", "array"}, {"items", {{"type", "object"}}}}}}}})},
             {"responses", {{"201", JsonResponse("the stream {id, channels[], …}")}}}}},
      kSmallRequestBytes));

  Route frames{
      "POST",
      "/api/v1/streams/{id}/frames",
      "Send stream frames (binary application/vnd.kinemetric.stream-frame or "
      "application/x-ndjson); the body may be long and chunked: frames are stored as they "
      "arrive, the answer comes when the body ends",
      true,
      [svc](const Request& req) {
        // Callers that hold the whole body (tests, tools); the HTTP server uses open_body.
        FrameIngestion ingestion(svc->streams(), req.PathId("id"),
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
       {"responses", {{"200", JsonResponse("{frames, samples, stored, duplicates, gaps[]}")}}}}};
  frames.open_body = [svc](const Request& req) -> std::unique_ptr<BodySink> {
    return std::make_unique<FrameSink>(*svc, req.PathId("id"),
                                       req.Header("content-type").value_or(""));
  };
  router.Add(std::move(frames));

  AddStreamReadRoutes(router, service);
  AddDeviceRoutes(router, service);
}

}  // namespace km::api
