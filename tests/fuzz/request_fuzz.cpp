// JSON request bodies checked without HTTP: the field helpers of server/base/request_json.h, and
// the service calls that validate a request before doing anything (Service::CreateStream, the
// study requests parsed and submitted (server/jobs/study_requests.h), Service::StreamProfile on
// a stream that holds samples). The body is the whole input; a body that is not JSON, or that
// ingest/json_text.h refuses (nesting, repeated keys, numbers beyond a double), is refused before
// any of these runs.
#include <cmath>
#include <limits>

#include "ingest/json_text.h"
#include "ingest/stream/stream_frames.h"
#include "server/base/request_json.h"
#include "tests/fuzz/fuzz_service.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using nlohmann::json;
namespace req = km::server::request;

constexpr km::server::StreamId kSeededStream(1);

// Stream 1: channel 1 a sensor, channel 2 an encoder, 200 samples each at 1 kHz.
void SeedStream(km::server::Service& svc) {
  const auto id = svc.streams().CreateStream(json{
      {"machine_id", "fuzz-vmc"}, {"channels", json::array({{{"channel", 1}}, {{"channel", 2}}})}});
  km::fuzz::Check(id == kSeededStream, "the seeded stream is stream 1");
  std::string body;
  for (std::uint32_t ch : {1u, 2u}) {
    km::ingest::SampleRun run;
    run.channel = ch;
    run.first_counter = 0;
    for (int k = 0; k < 200; ++k) {
      run.t_us.push_back(1'700'000'000'000'000 + 1000 * k);
      run.value_um.push_back(ch == 1 ? 0.01 * (k % 17) : 50.0 * k);
      run.status.push_back(0);
    }
    body += km::ingest::EncodeNdjsonRun(run);
  }
  svc.streams().IngestFrames(
      kSeededStream, std::string(km::ingest::kNdjsonContentType),
      [&](const std::function<bool(std::string_view)>& sink) { return sink(body); });
}

// A whole number the helper accepted is the number the request holds.
void CheckWhole(const json& j, const std::string& key, std::int64_t lo, std::int64_t hi) {
  const std::int64_t v = req::WholeNumber(j, key, lo, hi, std::nullopt);
  km::fuzz::Check(v >= lo && v <= hi, "WholeNumber stays within its bounds");
  const json& x = j.at(key);
  if (x.is_number_unsigned()) {
    km::fuzz::Check(v >= 0 && static_cast<std::uint64_t>(v) == x.get<std::uint64_t>(),
                    "WholeNumber returns the number of the request");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static km::fuzz::RecycledService service(2000, SeedStream);
  // Read as the server reads a request body (depth, repeated keys, numbers beyond a double).
  const json j = km::ingest::ParseJsonTextOrDiscarded(
      std::string_view(reinterpret_cast<const char*>(data), size));
  if (j.is_discarded()) return 0;
  auto& svc = service.Get();
  using km::fuzz::Guarded;
  Guarded([&] { req::RequiredString(j, "machine_id"); });
  Guarded([&] { req::OptionalString(j, "name", "fallback"); });
  Guarded([&] {
    const double v = req::Number(j, "feed_mm_min", std::nullopt);
    km::fuzz::Check(std::isfinite(v), "Number is finite");
  });
  Guarded([&] { req::Number(j, "start_mm", 0.0); });
  Guarded([&] { CheckWhole(j, "channel", 0, 65535); });
  Guarded([&] {
    CheckWhole(j, "from_us", std::numeric_limits<std::int64_t>::min(),
               std::numeric_limits<std::int64_t>::max());
  });
  Guarded([&] { svc.streams().CreateStream(j); });
  Guarded([&] { svc.studies().SubmitCalibration(km::server::CalibrationRequest::Parse(j)); });
  Guarded([&] { svc.studies().SubmitDiscovery(km::server::DiscoveryRequest::Parse(j)); });
  Guarded([&] { svc.streams().StreamProfile(kSeededStream, j); });
  return 0;
}
