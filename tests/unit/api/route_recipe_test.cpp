// The recipe for a new HTTP route (docs/architecture.md "Recipe: a new HTTP route"), followed
// once: an endpoint of a capability (here a test's own: the kinds of a machine's stored
// measurements, and a note an engineer posts), its line — method, path, role, endpoint — added
// by AddRoute exactly as the route table's lines are, on a server with every route of the table.
// The route then dispatches through the service, its errors become problem+json centrally, the
// role is enforced (401 without a token, 403 below the role), a state change is in the audit
// log, and GET /api/v1/openapi.json lists it with its summary and role.
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "api/endpoints.h"
#include "api/route_util.h"
#include "api/routes.h"
#include "tests/unit/api/token_routes.h"

namespace km::api {
namespace {

using nlohmann::json;

// The endpoint, as a capability's file writes it: summary, handler, OpenAPI detail.
Endpoint MachineKinds(const RouteContext& c) {
  server::Service* svc = &c.service;
  return {"How many measurements of each kind a machine has stored (404 when none)",
          [svc](const Request& req) {
            server::MeasurementFilter f;
            f.machine_id = req.path_params.at("machine_id");
            const json list = svc->measurements().ListMeasurements(f);
            if (list["items"].empty()) throw NotFound("no measurement of machine " + *f.machine_id);
            std::map<std::string, int> kinds;
            for (const auto& m : list["items"]) ++kinds[m["kind"].get<std::string>()];
            return Response::Json({{"machine_id", *f.machine_id}, {"kinds", kinds}});
          },
          {{"responses", {{"200", JsonResponse("{machine_id, kinds{kind: count}}")}}}}};
}

Endpoint MachineNote(const RouteContext&) {
  return {"A note on a machine (an engineer's)",
          [](const Request& req) {
            const json body = json::parse(req.body, nullptr, false);
            if (!body.is_object() || !body.contains("text") || !body["text"].is_string()) {
              throw InvalidInput("", 0, "text", "a note needs its text");
            }
            return Response::Json(
                {{"machine_id", req.path_params.at("machine_id")}, {"text", body["text"]}});
          },
          {{"responses", {{"200", JsonResponse("{machine_id, text}")}}}}};
}

class RouteRecipeTest : public test::TokenRoutesTest {
 protected:
  void SetUp() override {
    TokenRoutesTest::SetUp();
    const RouteContext context{*svc_, router_};
    // The recipe's one line per route, as in api/routes.cpp's table.
    AddRoute(router_, context,
             {"GET", "/api/v1/machines/{machine_id}/kinds", server::Role::kViewer, MachineKinds});
    AddRoute(router_, context,
             {"POST", "/api/v1/machines/{machine_id}/notes", server::Role::kEngineer, MachineNote});
  }
  void Upload(const std::string& example) {
    std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + example,
                     std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    svc_->measurements().Upload(bytes.str(), example);
  }
};

TEST_F(RouteRecipeTest, TheNewRouteAnswersThroughTheService) {
  Upload("dbb_xy-r150_ccw.txt");
  Upload("dbb_xy-r150_cw.txt");
  const std::string viewer = Token("viewer");
  const auto r = Call("GET", "/api/v1/machines/vmc-3axis/kinds", viewer);
  ASSERT_EQ(r.status, 200) << r.body;
  const json j = json::parse(r.body);
  EXPECT_EQ(j["machine_id"], "vmc-3axis");
  EXPECT_EQ(j["kinds"]["dbb"], 2);
  // A typed error of the handler is mapped in one place: 404 as problem+json.
  const auto none = Call("GET", "/api/v1/machines/no-such-machine/kinds", viewer);
  EXPECT_EQ(none.status, 404);
  EXPECT_NE(none.body.find("no measurement of machine no-such-machine"), std::string::npos);
  const auto bad = Call("POST", "/api/v1/machines/demo-vmc/notes", "boot", R"({"txt": 1})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(bad.body.find("text"), std::string::npos);
}

TEST_F(RouteRecipeTest, TheRoleOfItsLineIsEnforcedAndAChangeIsInTheAuditLog) {
  EXPECT_EQ(Call("GET", "/api/v1/machines/demo-vmc/kinds", "").status, 401);
  EXPECT_EQ(Call("GET", "/api/v1/machines/demo-vmc/kinds", "not-a-token").status, 401);
  const std::string note = R"({"text": "spindle warmed 20 min"})";
  EXPECT_EQ(Call("POST", "/api/v1/machines/demo-vmc/notes", Token("viewer")).status, 403);
  EXPECT_EQ(Call("POST", "/api/v1/machines/demo-vmc/notes", Token("operator"), note).status, 403);
  const auto ok = Call("POST", "/api/v1/machines/demo-vmc/notes", Token("engineer"), note);
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_EQ(json::parse(ok.body)["text"], "spindle warmed 20 min");
  const json log = svc_->access().AuditLog(50, 0);
  bool found = false;
  for (const auto& e : log["items"]) {
    if (e["path"] == "/api/v1/machines/demo-vmc/notes" && e["method"] == "POST" &&
        e["status"] == 200) {
      found = e["role"] == "engineer";
    }
  }
  EXPECT_TRUE(found) << log.dump();
}

TEST_F(RouteRecipeTest, TheOpenApiDocumentListsItWithItsRole) {
  const auto r = Call("GET", "/api/v1/openapi.json", "");
  ASSERT_EQ(r.status, 200);
  const json doc = json::parse(r.body);
  const json& kinds = doc["paths"]["/api/v1/machines/{machine_id}/kinds"]["get"];
  EXPECT_EQ(kinds["summary"],
            "How many measurements of each kind a machine has stored (404 when none)");
  EXPECT_EQ(kinds["x-required-role"], "viewer");
  EXPECT_EQ(doc["paths"]["/api/v1/machines/{machine_id}/notes"]["post"]["x-required-role"],
            "engineer");
  // The table's own routes are all still there.
  EXPECT_TRUE(doc["paths"].contains("/api/v1/measurements/{id}/results"));
}

}  // namespace
}  // namespace km::api
