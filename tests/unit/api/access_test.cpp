// Access control against the real router, service and SQLite storage: the role of every route
// (in the table and the OpenAPI document), every route × {no token, wrong token, each role},
// tokens made, listed without secrets, expired and revoked at once, and the audit log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <thread>

#include "analysis/core/errors.h"
#include "api/http.h"
#include "api/routes.h"
#include "server/access/access.h"
#include "server/base/sha256.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using server::Role;

// Every route of the API with the role it needs. A route added without being listed here fails
// RoutesDeclareTheirRoles: nothing is silently open.
const std::map<std::string, Role>& ExpectedRoles() {
  static const std::map<std::string, Role> roles = {
      {"GET /healthz", Role::kPublic},
      {"GET /api/v1/openapi.json", Role::kPublic},
      {"POST /api/v1/measurements", Role::kOperator},
      {"GET /api/v1/measurements", Role::kViewer},
      {"GET /api/v1/measurements/{id}", Role::kViewer},
      {"GET /api/v1/measurements/{id}/results", Role::kViewer},
      {"GET /api/v1/measurements/{id}/trace", Role::kViewer},
      {"GET /api/v1/measurements/{id}/pair", Role::kViewer},
      {"GET /api/v1/measurements/{id}/reversal", Role::kViewer},
      {"GET /api/v1/measurements/{id}/compensation", Role::kViewer},
      {"GET /api/v1/measurements/{id}/report.pdf", Role::kViewer},
      {"GET /api/v1/jobs/{id}/report.pdf", Role::kViewer},
      {"GET /api/v1/machines/{machine_id}/audit/report.pdf", Role::kViewer},
      {"GET /api/v1/measurements/{id}/report/revisions", Role::kViewer},
      {"GET /api/v1/jobs/{id}/report/revisions", Role::kViewer},
      {"GET /api/v1/machines/{machine_id}/audit/report/revisions", Role::kViewer},
      {"POST /api/v1/measurements/{id}/report/approve", Role::kEngineer},
      {"POST /api/v1/jobs/{id}/report/approve", Role::kEngineer},
      {"POST /api/v1/machines/{machine_id}/audit/report/approve", Role::kEngineer},
      {"GET /api/v1/measurements/{id}/plot.png", Role::kViewer},
      {"GET /api/v1/measurements/{id}/servo/force", Role::kViewer},
      {"GET /api/v1/machines/{machine_id}/joint-health", Role::kViewer},
      {"PUT /api/v1/machines/{machine_id}/audit", Role::kEngineer},
      {"GET /api/v1/machines/{machine_id}/audit", Role::kViewer},
      {"POST /api/v1/machines/{machine_id}/audit/run", Role::kEngineer},
      {"GET /api/v1/audits", Role::kViewer},
      {"GET /api/v1/audits/{id}", Role::kViewer},
      {"GET /api/v1/audit-metrics", Role::kViewer},
      {"PUT /api/v1/machines/{machine_id}/tolerances", Role::kEngineer},
      {"GET /api/v1/machines/{machine_id}/tolerances", Role::kViewer},
      {"PUT /api/v1/instruments/{serial}", Role::kEngineer},
      {"GET /api/v1/instruments/{serial}", Role::kViewer},
      {"GET /api/v1/instruments", Role::kViewer},
      {"GET /api/v1/fleet", Role::kViewer},
      {"GET /api/v1/machines/{machine_id}/trends", Role::kViewer},
      {"POST /api/v1/calibrations", Role::kEngineer},
      {"GET /api/v1/jobs/{id}", Role::kViewer},
      {"GET /api/v1/jobs", Role::kViewer},
      {"GET /api/v1/machines", Role::kViewer},
      {"POST /api/v1/machines", Role::kEngineer},
      {"GET /api/v1/machines/{machine_id}/definition", Role::kViewer},
      {"GET /api/v1/machines/{machine_id}/definitions", Role::kViewer},
      {"POST /api/v1/discoveries", Role::kEngineer},
      {"POST /api/v1/jobs/{id}/save-machine", Role::kEngineer},
      {"DELETE /api/v1/jobs/{id}", Role::kEngineer},
      {"POST /api/v1/streams", Role::kOperator},
      {"POST /api/v1/streams/{id}/frames", Role::kOperator},
      {"GET /api/v1/streams", Role::kViewer},
      {"GET /api/v1/streams/{id}", Role::kViewer},
      {"GET /api/v1/streams/{id}/samples", Role::kViewer},
      {"GET /api/v1/streams/{id}/gaps", Role::kViewer},
      {"POST /api/v1/streams/{id}/profile", Role::kOperator},
      {"POST /api/v1/streams/{id}/servo", Role::kOperator},
      {"GET /api/v1/devices", Role::kAdmin},
      {"POST /api/v1/devices", Role::kAdmin},
      {"DELETE /api/v1/devices/{name}", Role::kAdmin},
      {"POST /api/v1/servo/identify", Role::kEngineer},
      {"POST /api/v1/servo/joints", Role::kOperator},
      {"POST /api/v1/tokens", Role::kAdmin},
      {"GET /api/v1/tokens", Role::kAdmin},
      {"DELETE /api/v1/tokens/{id}", Role::kAdmin},
      {"GET /api/v1/audit-log", Role::kAdmin},
      {"GET /api/v1/whoami", Role::kViewer},
      {"GET /metrics", Role::kViewer},
  };
  return roles;
}

// A request path for a route pattern: every {param} filled with a value naming nothing stored.
std::string FillPattern(const std::string& pattern) {
  std::string out;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '{') {
      out += pattern[i];
      continue;
    }
    const auto close = pattern.find('}', i);
    out += pattern.substr(i + 1, close - i - 1) == "id" ? "99999" : "nothing-here";
    i = close;
  }
  return out;
}

class Access : public testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::temp_directory_path() / ("km-access-" + std::to_string(::getpid()) + "-" +
                                     testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    svc_ = std::make_unique<server::Service>(
        std::make_unique<server::SqliteStorage>((dir_ / "km.db").string()),
        server::ServiceOptions{});
    server::RegisterBuiltinKinds(svc_->measurements());
    AddRoutes(router_, *svc_);
    router_.SetHook(TokenHook(*svc_));
    router_.SetObserver(AuditHook(*svc_));
    ASSERT_EQ(svc_->access().EnsureAdminToken("boot"), "");
  }
  void TearDown() override {
    svc_.reset();
    fs::remove_all(dir_);
  }

  Response Call(const std::string& method, const std::string& path, const std::string& token,
                const std::string& body = "") {
    Request req;
    req.method = method;
    const auto q = path.find('?');
    req.path = path.substr(0, q);
    if (q != std::string::npos) {
      const std::string query = path.substr(q + 1);
      const auto eq = query.find('=');
      req.query.emplace(query.substr(0, eq), query.substr(eq + 1));
    }
    if (!token.empty()) req.headers["authorization"] = "Bearer " + token;
    req.body = body;
    return router_.Dispatch(req);
  }

  // A new token of the role through the API: {id, token, ...}.
  json NewToken(const std::string& role, const std::string& name,
                std::optional<int> expires_in_s = std::nullopt) {
    json body = {{"name", name}, {"role", role}};
    if (expires_in_s) body["expires_in_s"] = *expires_in_s;
    const auto r = Call("POST", "/api/v1/tokens", "boot", body.dump());
    EXPECT_EQ(r.status, 201) << r.body;
    return json::parse(r.body);
  }

  fs::path dir_;
  std::unique_ptr<server::Service> svc_;
  Router router_;
};

TEST_F(Access, RoutesDeclareTheirRolesInTheTableAndTheOpenApiDocument) {
  const auto& want = ExpectedRoles();
  std::size_t seen = 0;
  for (const auto& r : router_.routes()) {
    const std::string key = r.method + " " + r.pattern;
    const auto it = want.find(key);
    ASSERT_NE(it, want.end()) << key << " is not listed with its role in this test";
    EXPECT_EQ(RequiredRole(r), it->second) << key;
    ++seen;
  }
  EXPECT_EQ(seen, want.size()) << "a listed route is gone";
  const json doc = json::parse(Call("GET", "/api/v1/openapi.json", "").body);
  for (const auto& [key, role] : want) {
    const auto space = key.find(' ');
    std::string method = key.substr(0, space);
    for (auto& c : method) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto& op = doc["paths"][key.substr(space + 1)][method];
    EXPECT_EQ(op.value("x-required-role", ""), server::RoleName(role)) << key;
  }
}

TEST_F(Access, EveryRouteRefusesMissingWrongAndLowerTokensAndAdmitsItsRole) {
  std::map<Role, std::string> tokens = {{Role::kAdmin, "boot"}};
  for (const Role r : {Role::kViewer, Role::kOperator, Role::kEngineer}) {
    tokens[r] = NewToken(server::RoleName(r), std::string("t-") + server::RoleName(r))["token"];
  }
  for (const auto& route : router_.routes()) {
    const std::string path = FillPattern(route.pattern);
    const std::string key = route.method + " " + route.pattern;
    const Role need = RequiredRole(route);
    const bool reads = route.method == "GET";
    const std::string body = reads ? "" : "{}";
    for (const std::string bad : {"", "not-a-token"}) {
      const auto r = Call(route.method, path, bad, body);
      if (need == Role::kPublic) {
        EXPECT_LT(r.status, 400) << key;
      } else {
        EXPECT_EQ(r.status, 401) << key << " token '" << bad << "'";
        EXPECT_EQ(r.content_type, "application/problem+json") << key;
      }
    }
    for (const auto& [role, token] : tokens) {
      const auto r = Call(route.method, path, token, body);
      if (role < need) {
        EXPECT_EQ(r.status, 403) << key << " as " << server::RoleName(role);
        EXPECT_EQ(r.content_type, "application/problem+json");
        EXPECT_NE(r.body.find(std::string("'") + server::RoleName(need) + "'"), std::string::npos)
            << key << ": " << r.body;
      } else {
        EXPECT_NE(r.status, 401) << key << " as " << server::RoleName(role) << ": " << r.body;
        EXPECT_NE(r.status, 403) << key << " as " << server::RoleName(role) << ": " << r.body;
        EXPECT_LT(r.status, 500) << key << " as " << server::RoleName(role) << ": " << r.body;
      }
    }
  }
}

TEST_F(Access, TokensAreShownOnceListedWithoutSecretsAndCheckedField) {
  const json t = NewToken("operator", "line 3 uploader", 3600);
  ASSERT_TRUE(t["token"].is_string());
  const std::string secret = t["token"];
  EXPECT_EQ(secret.size(), 64u);  // 256 bits, hex
  EXPECT_EQ(t["role"], "operator");
  EXPECT_EQ(t["name"], "line 3 uploader");
  EXPECT_TRUE(t["expires_at"].is_string());
  EXPECT_GT(t["id"].get<std::int64_t>(), 1);
  // Stored hashed: the secret is nowhere in the database's token row.
  const auto stored = svc_->storage().FindToken(server::Sha256Hex(secret));
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored->role, "operator");

  const auto list = Call("GET", "/api/v1/tokens", "boot");
  ASSERT_EQ(list.status, 200);
  EXPECT_EQ(list.body.find(secret), std::string::npos);
  EXPECT_EQ(list.body.find(server::Sha256Hex(secret)), std::string::npos);
  EXPECT_EQ(list.body.find(server::Sha256Hex("boot")), std::string::npos);
  const json items = json::parse(list.body)["items"];
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[1]["name"], "line 3 uploader");
  EXPECT_EQ(items[1]["state"], "active");
  EXPECT_FALSE(items[1].contains("token"));
  // Last use: the admin's request of the list is recorded; the new token was not used yet.
  EXPECT_TRUE(items[0]["last_used_at"].is_string()) << items[0];
  EXPECT_TRUE(items[1]["last_used_at"].is_null()) << items[1];
  const auto me = json::parse(Call("GET", "/api/v1/whoami", secret).body);
  EXPECT_EQ(me, (json{{"token_id", t["id"]}, {"name", "line 3 uploader"}, {"role", "operator"}}));
  const json used = json::parse(Call("GET", "/api/v1/tokens", "boot").body)["items"][1];
  ASSERT_TRUE(used["last_used_at"].is_string()) << used;
  EXPECT_EQ(used["last_used_at"].get<std::string>().size(), 20u);  // YYYY-MM-DDTHH:MM:SSZ

  const auto bad = [&](const json& body, const std::string& field) {
    const auto r = Call("POST", "/api/v1/tokens", "boot", body.dump());
    EXPECT_EQ(r.status, 400) << body.dump();
    EXPECT_EQ(json::parse(r.body).value("field", ""), field) << r.body;
  };
  bad({{"role", "viewer"}}, "name");
  bad({{"name", "x"}, {"role", "root"}}, "role");
  bad({{"name", "x"}}, "role");
  bad({{"name", "x"}, {"role", "viewer"}, {"expires_in_s", 0}}, "expires_in_s");
  bad({{"name", "x"}, {"role", "viewer"}, {"expires_in_s", "soon"}}, "expires_in_s");
  bad({{"name", "x"}, {"role", "viewer"}, {"scope", "all"}}, "scope");
  bad({{"name", "a\nb"}, {"role", "viewer"}}, "name");
  // Every control or line-breaking character, as a JSON escape and as raw UTF-8 bytes: C0, DEL,
  // C1 (U+0080, U+0085 NEL, U+009F), U+2028, U+2029.
  for (const std::string& c :
       {std::string("\\u0000"), std::string("\\t"), std::string("\\u001f"), std::string("\\u007f"),
        std::string("\\u0080"), std::string("\\u0085"), std::string("\\u009f"),
        std::string("\\u2028"), std::string("\\u2029"), std::string("\x7f"),
        std::string("\xC2\x85"), std::string("\xC2\x9F"), std::string("\xE2\x80\xA8"),
        std::string("\xE2\x80\xA9")}) {
    const std::string body = R"({"name": "line 3)" + c + R"(uploader", "role": "viewer"})";
    const auto r = Call("POST", "/api/v1/tokens", "boot", body);
    EXPECT_EQ(r.status, 400) << ::testing::PrintToString(body);
    EXPECT_EQ(json::parse(r.body).value("field", ""), "name") << ::testing::PrintToString(body);
  }
  // Bytes that are not UTF-8: a body holding them is not JSON (400); a name that reaches the
  // service another way is refused naming the field.
  for (const std::string& c : {std::string("\xFF"), std::string("\xC2"),
                               std::string("\xED\xA0\x80"), std::string("\xC0\x8A")}) {
    const std::string name = "line 3" + c + "uploader";
    EXPECT_EQ(
        Call("POST", "/api/v1/tokens", "boot", R"({"name": ")" + name + R"(", "role": "viewer"})")
            .status,
        400)
        << ::testing::PrintToString(name);
    try {
      (void)svc_->access().CreateToken(json{{"name", name}, {"role", "viewer"}});
      ADD_FAILURE() << "accepted " << ::testing::PrintToString(name);
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "name") << ::testing::PrintToString(name);
    }
  }
  // Printable text beyond ASCII stays accepted, including the neighbours of the refused ranges.
  for (const std::string& ok :
       {std::string("Prüfstand \xC2\xA0"
                    "A"),
        std::string("\xE2\x80\xA7"), std::string("\xE2\x80\xAF"), std::string("\xC2\xA0")}) {
    const auto r =
        Call("POST", "/api/v1/tokens", "boot", R"({"name": ")" + ok + R"(", "role": "viewer"})");
    EXPECT_EQ(r.status, 201) << ::testing::PrintToString(ok) << " " << r.body;
  }
  EXPECT_EQ(Call("POST", "/api/v1/tokens", "boot", "[1]").status, 400);
  EXPECT_EQ(Call("POST", "/api/v1/tokens", "boot", "not json").status, 400);
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/tokens", "boot").body)["items"].size(), 2u + 4u);
}

TEST_F(Access, ExpiredTokensAreRefusedWith401EvenWhenRecentlyAccepted) {
  svc_->storage().AddToken(server::Sha256Hex("old"), "admin", "old", "2020-01-01T00:00:00Z");
  const auto r = Call("GET", "/api/v1/machines", "old");
  EXPECT_EQ(r.status, 401);
  EXPECT_NE(r.body.find("expired"), std::string::npos) << r.body;

  const std::string soon = NewToken("viewer", "short", 2)["token"];
  EXPECT_EQ(Call("GET", "/api/v1/machines", soon).status, 200);  // accepted and cached
  std::this_thread::sleep_for(std::chrono::milliseconds(2100));
  const auto late = Call("GET", "/api/v1/machines", soon);
  EXPECT_EQ(late.status, 401) << late.body;
  EXPECT_NE(late.body.find("expired"), std::string::npos) << late.body;
  const json items = json::parse(Call("GET", "/api/v1/tokens", "boot").body)["items"];
  EXPECT_EQ(items.back()["state"], "expired");
}

TEST_F(Access, RevocationTakesEffectAtOnce) {
  const json t = NewToken("engineer", "to revoke");
  const std::string secret = t["token"];
  EXPECT_EQ(Call("GET", "/api/v1/machines", secret).status, 200);  // now in the token cache
  const auto del = Call("DELETE", "/api/v1/tokens/" + t["id"].dump(), "boot");
  ASSERT_EQ(del.status, 200) << del.body;
  EXPECT_TRUE(json::parse(del.body)["revoked_at"].is_string());
  const auto r = Call("GET", "/api/v1/machines", secret);
  EXPECT_EQ(r.status, 401);
  EXPECT_NE(r.body.find("revoked"), std::string::npos) << r.body;
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/tokens", "boot").body)["items"][1]["state"],
            "revoked");
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/777", "boot").status, 404);
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/x", "boot").status, 400);
  // A bad id is named as what the path holds: a token id, not a measurement id.
  const auto negative = Call("DELETE", "/api/v1/tokens/-1", "boot");
  EXPECT_EQ(negative.status, 400);
  EXPECT_NE(negative.body.find("'-1' is not a token id (a positive integer)"), std::string::npos)
      << negative.body;
  for (const auto& [path, noun] :
       std::map<std::string, std::string>{{"/api/v1/jobs/0", "a job id"},
                                          {"/api/v1/measurements/abc/trace", "a measurement id"},
                                          {"/api/v1/audits/-2", "an audit id"},
                                          {"/api/v1/streams/1.5", "a stream id"}}) {
    const auto r = Call("GET", path, "boot");
    EXPECT_EQ(r.status, 400) << path;
    EXPECT_NE(r.body.find("is not " + noun + " (a positive integer)"), std::string::npos)
        << path << ": " << r.body;
  }
  // A second revocation keeps the first time.
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/" + t["id"].dump(), "boot").body, del.body);

  // The last active admin token stays: revoking it would leave nobody to make tokens.
  const auto last = Call("DELETE", "/api/v1/tokens/1", "boot");
  EXPECT_EQ(last.status, 409) << last.body;
  EXPECT_NE(last.body.find("last active admin"), std::string::npos) << last.body;
  // An admin token that expires is not the admin that remains.
  const json expiring = NewToken("admin", "for an hour", 3600);
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/1", "boot").status, 409);
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/1", expiring["token"]).status, 409);
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/" + expiring["id"].dump(), "boot").status, 200);
  const json second = NewToken("admin", "second admin");
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/1", second["token"]).status, 200);
  EXPECT_EQ(Call("GET", "/api/v1/machines", "boot").status, 401);
  EXPECT_EQ(Call("DELETE", "/api/v1/tokens/" + second["id"].dump(), second["token"]).status, 409);
}

TEST_F(Access, TheAuditLogRecordsWhoChangedWhatNewestFirst) {
  const json op = NewToken("operator", "uploader");
  const json viewer = NewToken("viewer", "reader");
  const auto file = server::DemoDbbFiles().at(0);
  const auto up = Call("POST", "/api/v1/measurements", op["token"], file.bytes);
  ASSERT_EQ(up.status, 201) << up.body;
  const auto mid = json::parse(up.body)["id"].get<std::int64_t>();
  EXPECT_EQ(Call("GET", "/api/v1/measurements/" + std::to_string(mid), op["token"]).status, 200);
  EXPECT_EQ(Call("POST", "/api/v1/calibrations", viewer["token"], "{}").status, 403);
  EXPECT_EQ(Call("POST", "/api/v1/measurements", "wrong", file.bytes).status, 401);
  ASSERT_EQ(Call("DELETE", "/api/v1/tokens/" + viewer["id"].dump(), "boot").status, 200);

  const auto r = Call("GET", "/api/v1/audit-log", "boot");
  ASSERT_EQ(r.status, 200);
  const json log = json::parse(r.body);
  // Two token creations, the upload, the refusals, the revocation; no GET.
  ASSERT_EQ(log["total"], 6) << log.dump(1);
  const json& items = log["items"];
  EXPECT_EQ(items[0]["method"], "DELETE");
  EXPECT_EQ(items[0]["subject"], "token " + viewer["id"].dump());
  EXPECT_EQ(items[0]["token_name"], "bootstrap");
  EXPECT_EQ(items[0]["role"], "admin");
  EXPECT_EQ(items[0]["status"], 200);
  EXPECT_EQ(items[1]["status"], 401);
  EXPECT_TRUE(items[1]["token_id"].is_null());
  EXPECT_EQ(items[2]["status"], 403);
  EXPECT_EQ(items[2]["token_name"], "reader");
  EXPECT_EQ(items[2]["path"], "/api/v1/calibrations");
  EXPECT_EQ(items[3]["method"], "POST");
  EXPECT_EQ(items[3]["path"], "/api/v1/measurements");
  EXPECT_EQ(items[3]["status"], 201);
  EXPECT_EQ(items[3]["token_id"], op["id"]);
  EXPECT_EQ(items[3]["token_name"], "uploader");
  EXPECT_EQ(items[3]["role"], "operator");
  EXPECT_EQ(items[3]["subject"], "measurement " + std::to_string(mid));
  EXPECT_EQ(items[5]["subject"], "token " + op["id"].dump());
  EXPECT_FALSE(items[0]["at"].get<std::string>().empty());
  EXPECT_EQ(r.body.find(op["token"].get<std::string>()), std::string::npos);

  const json page = json::parse(Call("GET", "/api/v1/audit-log?offset=5", "boot").body);
  ASSERT_EQ(page["items"].size(), 1u);
  EXPECT_EQ(page["items"][0]["id"], items[5]["id"]);
  EXPECT_EQ(Call("GET", "/api/v1/audit-log?limit=0", "boot").status, 400);
  EXPECT_EQ(Call("GET", "/api/v1/audit-log", op["token"]).status, 403);
}

}  // namespace
}  // namespace km::api
