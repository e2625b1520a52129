// The tolerance routes through the route table with tokens and the audit log (api/routes.cpp,
// api/tolerance_routes.cpp): a viewer may read but not store a table (403), an engineer stores
// versions, bad entries are 400 naming the field, a machine without a table or version is 404,
// every PUT is in the audit log; the upload answer and the list carry each measurement's
// conformance, which follows the newest table.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <sstream>

#include "tests/unit/api/token_routes.h"

namespace km::api {
namespace {

using nlohmann::json;

class ToleranceRoutes : public test::TokenRoutesTest {
 protected:
  void SetUp() override {
    TokenRoutesTest::SetUp();
    viewer_ = Token("viewer");
    engineer_ = Token("engineer");
  }
  Response Put(const json& tolerances, const std::string& token) {
    return Call("PUT", "/api/v1/machines/vmc-3axis/tolerances", token,
                json{{"tolerances", tolerances}}.dump());
  }
  std::string viewer_, engineer_;
};

const char* const kPath = "/api/v1/machines/vmc-3axis/tolerances";

json G(double tolerance) {
  return {{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", tolerance}};
}

std::string Example(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_F(ToleranceRoutes, RolesVersionsErrorsAndTheAuditLog) {
  EXPECT_EQ(Call("GET", kPath, viewer_).status, 404);
  const auto refused = Put(json::array({G(15)}), viewer_);
  EXPECT_EQ(refused.status, 403);
  EXPECT_NE(refused.body.find("engineer"), std::string::npos) << refused.body;
  const auto v1 = Put(json::array({G(15)}), engineer_);
  ASSERT_EQ(v1.status, 200) << v1.body;
  EXPECT_EQ(json::parse(v1.body)["version"], 1);
  EXPECT_EQ(json::parse(v1.body)["created"], true);
  EXPECT_EQ(json::parse(Put(json::array({G(15)}), engineer_).body)["created"], false);
  EXPECT_EQ(json::parse(Put(json::array({G(12)}), engineer_).body)["version"], 2);
  const auto got = Call("GET", kPath, viewer_);
  ASSERT_EQ(got.status, 200);
  EXPECT_EQ(json::parse(got.body)["version"], 2);
  EXPECT_EQ(json::parse(got.body)["tolerances"][0]["tolerance"], 12.0);
  EXPECT_EQ(json::parse(Call("GET", std::string(kPath) + "?version=1", viewer_)
                            .body)["tolerances"][0]["tolerance"],
            15.0);
  EXPECT_EQ(Call("GET", std::string(kPath) + "?version=3", viewer_).status, 404);
  for (const char* bad : {"0", "x", "1.5"}) {
    const auto r = Call("GET", std::string(kPath) + "?version=" + bad, viewer_);
    EXPECT_EQ(r.status, 400) << bad;
    EXPECT_EQ(json::parse(r.body).value("field", ""), "version");
  }
  json bad = G(1);
  bad["metric"] = "roundness_um";
  const auto r400 = Put(json::array({G(1), {{"kind", "flatness"}}, bad}), engineer_);
  EXPECT_EQ(r400.status, 400);
  EXPECT_EQ(r400.content_type, "application/problem+json");
  EXPECT_EQ(json::parse(r400.body).value("field", ""), "tolerances[1].metric") << r400.body;
  EXPECT_EQ(json::parse(Put(json::array({G(1), G(2), bad}), engineer_).body).value("field", ""),
            "tolerances[1]");
  const auto not_json = Call("PUT", kPath, engineer_, "{\"tolerances\": [");
  EXPECT_EQ(not_json.status, 400);
  // Every PUT is in the audit log, the refused ones too, naming machine and version.
  const auto log = json::parse(Call("GET", "/api/v1/audit-log", "boot").body)["items"];
  int puts = 0;
  bool named = false;
  for (const auto& e : log) {
    if (e["method"] != "PUT") continue;
    ++puts;
    named = named || e["subject"] == "machine vmc-3axis, tolerances version 2";
  }
  EXPECT_EQ(puts, 7);
  EXPECT_TRUE(named) << log.dump();
}

TEST_F(ToleranceRoutes, TheUploadAnswerAndTheListCarryTheConformance) {
  ASSERT_EQ(Put(json::array({G(0.5)}), engineer_).status, 200);
  Request up;
  up.method = "POST";
  up.path = "/api/v1/measurements";
  up.headers["authorization"] = "Bearer " + Token("operator");
  up.body = Example("dbb_xy-r150_ccw.txt");
  const auto stored = router_.Dispatch(up);
  ASSERT_EQ(stored.status, 201) << stored.body;
  const json answer = json::parse(stored.body);
  EXPECT_EQ(answer["conformance"]["verdict"], "fail");  // G of the example is above 0.5 µm
  EXPECT_EQ(answer["conformance"]["tolerance_version"], 1);
  const std::string id = answer["id"].dump();
  ASSERT_EQ(Put(json::array({G(1000)}), engineer_).status, 200);
  const auto list = json::parse(Call("GET", "/api/v1/measurements", viewer_).body);
  EXPECT_EQ(list["items"][0]["conformance"]["verdict"], "pass");
  EXPECT_EQ(list["items"][0]["conformance"]["tolerance_version"], 2);
  const auto results =
      json::parse(Call("GET", "/api/v1/measurements/" + id + "/results", viewer_).body);
  EXPECT_EQ(results["conformance"]["verdict"], "pass");
  const auto one = json::parse(Call("GET", "/api/v1/measurements/" + id, viewer_).body);
  EXPECT_EQ(one["conformance"]["verdict"], "pass");
}

}  // namespace
}  // namespace km::api
