#include "server/service.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "analysis/core/errors.h"
#include "api/http.h"
#include "api/routes.h"
#include "server/demo_data.h"
#include "server/sqlite_storage.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

TEST(Service, DemoDataGoesThroughTheNormalPathAndRoutesAnswer) {
  const fs::path db =
      fs::temp_directory_path() / ("km-service-" + std::to_string(::getpid()) + ".db");
  fs::remove(db);
  {
    Service svc(std::make_unique<SqliteStorage>(db.string()), {});
    RegisterBuiltinKinds(svc);
    const auto files = DemoDbbFiles();
    ASSERT_GE(files.size(), 6u);
    for (const auto& f : files) EXPECT_TRUE(svc.Upload(f.bytes, f.name).created) << f.name;
    const auto machines = svc.storage().ListMachines();
    ASSERT_EQ(machines.size(), 1u);
    EXPECT_EQ(machines[0].measurement_count, static_cast<std::int64_t>(files.size()));
    // Demo traces carry a visible error: circularity of several µm, CW and CCW differ.
    const auto r1 = svc.Results(1), r2 = svc.Results(2);
    EXPECT_GT(r1["circularity_um"].get<double>(), 2.0);
    EXPECT_NE(r1["circularity_um"], r2["circularity_um"]);

    api::Router router;
    api::AddRoutes(router, svc);
    router.SetHook(api::TokenHook(svc.storage()));
    EXPECT_EQ(api::EnsureAdminToken(svc.storage(), "boot"), "");
    api::Request req;
    req.method = "GET";
    req.path = "/api/v1/machines";
    EXPECT_EQ(router.Dispatch(req).status, 401);
    req.headers["authorization"] = "Bearer boot";
    EXPECT_EQ(router.Dispatch(req).status, 200);
    req.method = "DELETE";
    EXPECT_EQ(router.Dispatch(req).status, 405);
    api::Request bad;
    bad.method = "POST";
    bad.path = "/api/v1/measurements";
    bad.headers["authorization"] = "Bearer boot";
    bad.body = "# format: kinemetric-unknown/1\n";
    const auto resp = router.Dispatch(bad);
    EXPECT_EQ(resp.status, 400);
    EXPECT_EQ(resp.content_type, "application/problem+json");
    EXPECT_NE(resp.body.find("unknown format"), std::string::npos);

    // The OpenAPI document declares every path parameter of every route exactly once.
    const auto doc = api::OpenApiDocument(router, "test");
    std::size_t operations = 0;
    for (const auto& [path, ops] : doc["paths"].items()) {
      for (const auto& [method, op] : ops.items()) {
        ++operations;
        std::vector<std::string> declared;
        if (op.contains("parameters")) {
          for (const auto& prm : op["parameters"]) {
            if (prm["in"] == "path") declared.push_back(prm["name"].get<std::string>());
          }
        }
        std::vector<std::string> wanted;
        for (std::size_t o = path.find('{'); o != std::string::npos; o = path.find('{', o + 1)) {
          wanted.push_back(path.substr(o + 1, path.find('}', o) - o - 1));
        }
        std::sort(declared.begin(), declared.end());
        std::sort(wanted.begin(), wanted.end());
        EXPECT_EQ(declared, wanted) << method << " " << path;
      }
    }
    EXPECT_EQ(operations, router.routes().size());

    // The demo stream: 30 s of a capacitance sensor and the X encoder, one lost frame, and the
    // straightness profile made from it finds the injected 55 mm waviness and 10 mm lead.
    const auto stream = LoadDemoStream(svc);
    const auto sj = svc.StreamJson(stream);
    ASSERT_EQ(sj["channels"].size(), 2u);
    EXPECT_EQ(sj["gap_count"], 1);
    EXPECT_EQ(sj["missing"], 200);
    EXPECT_EQ(sj["channels"][1]["samples"], 60000);
    MeasurementFilter straightness;
    straightness.kind = "straightness";
    const auto profiles = svc.storage().ListMeasurements(straightness);
    ASSERT_EQ(profiles.items.size(), 1u);
    const auto pr = svc.Results(profiles.items[0].id);
    ASSERT_GE(pr["periodic"].size(), 2u) << pr.dump();
    EXPECT_NEAR(pr["periodic"][0]["period_mm"].get<double>(), 55.0, 55.0 * 0.02);
    EXPECT_NEAR(pr["periodic"][0]["amplitude_um"].get<double>(), 0.2, 0.01);
    EXPECT_NEAR(pr["periodic"][1]["period_mm"].get<double>(), 10.0, 10.0 * 0.02);
    EXPECT_NEAR(pr["periodic"][1]["amplitude_um"].get<double>(), 0.05, 0.005);
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

}  // namespace
}  // namespace km::server
