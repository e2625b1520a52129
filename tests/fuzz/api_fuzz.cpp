// The HTTP API without sockets: a Request is built from the input and dispatched by the route
// table of kinemetricd (api/routes.h) against a Service on an in-memory database that holds a
// few measurements and a sensor stream. This reaches the query-parameter helpers of
// api/route_util.h, path ids, JSON bodies and every handler. Input layout:
//   METHOD SP PATH[?QUERY] LF  then header lines "Name: value" LF, an empty line, the body.
// Unless the input names an Authorization header, the request carries a valid admin token.
// Not dispatched: POST /api/v1/devices (it would connect to the hosts named in the input) and
// POST /api/v1/calibrations (a study runs for minutes in the background; its request checks are
// fuzzed by the request target).
// Bodies of streamed routes (sensor frames) of odd length go through the route's body sink in
// pieces, as the HTTP server feeds them; even ones are passed whole, as tools do.
// A handler may refuse the request with a km::Error; any other exception, a status outside
// 100-599, a 500 without a product error, or a JSON answer that is not JSON is a finding.
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "api/http.h"
#include "api/routes.h"
#include "server/base/sha256.h"
#include "tests/fuzz/fuzz_service.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using nlohmann::json;
namespace api = km::api;

constexpr const char* kToken = "fuzz-admin-token";

bool g_product_error = false;  // a handler refused the current request with a km::Error

void SeedData(km::server::Service& svc) {
  for (const char* f :
       {"tests/fixtures/browser/dbb_xy-r150_cw.txt", "tests/fixtures/browser/dbb_xy-r150_ccw.txt",
        "tests/fixtures/browser/straightness_x_y.txt", "tests/fixtures/browser/flatness_table.txt",
        "tests/fixtures/browser/parallelism_x_tslot.txt",
        "tests/fixtures/browser/tracker_browser-vmc.txt"}) {
    const std::string bytes = km::fuzz::SourceFile(f);
    if (!bytes.empty()) svc.measurements().Upload(bytes, f);
  }
  // A hexapod model and a servo record of it (measurement 7): the servo routes.
  const std::string machine = km::fuzz::SourceFile("data/machines/pm600-like.json");
  if (!machine.empty()) svc.models().StoreMachineModel(machine, "upload", "fuzz");
  const std::string servo = km::fuzz::SourceFile("data/examples/servo_pm600-like_a_ccw.txt");
  if (!servo.empty()) svc.measurements().Upload(servo, "servo_pm600-like_a_ccw.txt");
  const auto stream = svc.streams().CreateStream(
      json{{"machine_id", "browser-test-vmc"},
           {"channels", json::array({{{"channel", 1}}, {{"channel", 2}}})}});
  std::string body;
  for (int k = 0; k < 64; ++k) {
    body += json{{"channel", 1 + k % 2},
                 {"counter", k / 2},
                 {"t_us", 1'700'000'000'000'000 + 500 * k},
                 {"value_um", 0.25 * k}}
                .dump() +
            "\n";
  }
  svc.streams().IngestFrames(
      stream, "application/x-ndjson",
      [&](const std::function<bool(std::string_view)>& sink) { return sink(body); });
  svc.storage().PutToken(km::server::Sha256Hex(kToken), "admin", "fuzz");
}

// Runs f; a km::Error refuses the request (noted for the 500 check), anything else is a finding.
template <typename F>
auto Product(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const km::Error&) {
    g_product_error = true;
    throw;
  } catch (const std::exception& e) {
    km::fuzz::Fail("a handler threw " + km::fuzz::TypeName(typeid(e)) + ": " + e.what());
  }
}

// Forwards a streamed body to the route's sink, reporting exceptions as above.
class CheckedSink : public api::BodySink {
 public:
  explicit CheckedSink(std::unique_ptr<api::BodySink> inner) : inner_(std::move(inner)) {}
  void Feed(std::string_view piece) override {
    Product([&] { inner_->Feed(piece); });
  }
  api::Response Finish(bool complete) override {
    return Product([&] { return inner_->Finish(complete); });
  }

 private:
  std::unique_ptr<api::BodySink> inner_;
};

struct Api {
  km::fuzz::RecycledService service{2000, SeedData};
  km::server::Service* current = nullptr;
  api::Router plain;  // the product's table; the OpenAPI route describes it, so it lives on
  api::Router router;

  // The route table of the current service, every handler, body sink and the access hook
  // wrapped by Product.
  api::Router& For(km::server::Service& svc) {
    if (current == &svc) return router;
    current = &svc;
    plain = api::Router();
    api::AddRoutes(plain, svc);
    router = api::Router();
    for (api::Route r : plain.routes()) {
      r.handler = [h = r.handler](const api::Request& req) {
        return Product([&] { return h(req); });
      };
      if (r.open_body) {
        r.open_body = [open =
                           r.open_body](const api::Request& req) -> std::unique_ptr<api::BodySink> {
          return std::make_unique<CheckedSink>(Product([&] { return open(req); }));
        };
      }
      router.Add(std::move(r));
    }
    router.SetHook(
        [hook = api::TokenHook(svc.storage())](api::Request& req, const api::Route& route) {
          Product([&] { hook(req, route); });
        });
    return router;
  }
};

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// application/x-www-form-urlencoded decoding, as the HTTP server does it.
std::string Decode(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && i + 2 < s.size() && HexValue(s[i + 1]) >= 0 &&
               HexValue(s[i + 2]) >= 0) {
      out += static_cast<char>(HexValue(s[i + 1]) * 16 + HexValue(s[i + 2]));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

std::string_view NextLine(std::string_view& s) {
  const auto nl = s.find('\n');
  std::string_view line = s.substr(0, nl);
  s = nl == std::string_view::npos ? std::string_view() : s.substr(nl + 1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

api::Request Parse(std::string_view in, std::string& body) {
  api::Request req;
  std::string_view first = NextLine(in);
  const auto sp = first.find(' ');
  req.method = sp == std::string_view::npos ? "GET" : std::string(first.substr(0, sp));
  std::string_view target = sp == std::string_view::npos ? first : first.substr(sp + 1);
  const auto q = target.find('?');
  req.path = Decode(target.substr(0, q));
  if (q != std::string_view::npos) {
    std::string_view query = target.substr(q + 1);
    while (!query.empty()) {
      const auto amp = query.find('&');
      const std::string_view pair = query.substr(0, amp);
      const auto eq = pair.find('=');
      req.query.emplace(Decode(pair.substr(0, eq)),
                        eq == std::string_view::npos ? "" : Decode(pair.substr(eq + 1)));
      query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    }
  }
  while (!in.empty()) {
    const std::string_view line = NextLine(in);
    if (line.empty()) break;
    const auto colon = line.find(':');
    std::string name(line.substr(0, colon));
    for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    std::string_view value = colon == std::string_view::npos ? "" : line.substr(colon + 1);
    while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
    req.headers[name] = std::string(value);
  }
  if (!req.headers.count("authorization")) {
    req.headers["authorization"] = std::string("Bearer ") + kToken;
  }
  body.assign(in);
  return req;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Api api_state;
  std::string body;
  api::Request req = Parse(km::fuzz::AsText(data, size), body);
  if (req.method == "POST" &&
      (req.path == "/api/v1/devices" || req.path == "/api/v1/calibrations")) {
    return 0;
  }
  auto& svc = api_state.service.Get();
  auto& router = api_state.For(svc);
  g_product_error = false;
  // As the HTTP server does it: admit from the headers, then either run the handler on the
  // whole body or, for routes that stream their body, feed it to the route's sink in pieces.
  api::Response res;
  try {
    const api::Route* route = router.Admit(req, res);
    if (route && route->open_body && !body.empty() && (body.size() & 1)) {
      try {
        auto sink = route->open_body(req);
        for (std::size_t at = 0; at < body.size(); at += 61) {
          sink->Feed(std::string_view(body).substr(at, 61));
        }
        res = sink->Finish(true);
      } catch (...) {
        res = api::ErrorResponse(std::current_exception(), req);
      }
    } else if (route) {
      req.body = body;
      res = router.Run(*route, req);
    }
  } catch (const std::exception& e) {
    km::fuzz::Fail("the router threw " + km::fuzz::TypeName(typeid(e)) + ": " + e.what());
  }
  if (std::getenv("KINEMETRIC_FUZZ_VERBOSE")) {  // when replaying inputs by hand
    std::fprintf(stderr, "%s %s -> %d %s\n", req.method.c_str(), req.path.c_str(), res.status,
                 res.body.substr(0, 160).c_str());
  }
  km::fuzz::Check(res.status >= 100 && res.status <= 599, "an HTTP status");
  if (res.status == 500 && !g_product_error) {
    km::fuzz::Fail("500 without a product error: " + res.body);
  }
  if (res.content_type.find("json") != std::string::npos) {
    km::fuzz::Check(!json::parse(res.body, nullptr, false).is_discarded(), "a JSON answer is JSON");
  }
  return 0;
}
