#include "server/service.h"

#include <gtest/gtest.h>

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
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

}  // namespace
}  // namespace km::server
