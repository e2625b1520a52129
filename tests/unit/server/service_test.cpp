#include "server/service.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <tuple>

#include "analysis/core/errors.h"
#include "api/http.h"
#include "api/routes.h"
#include "server/demo/demo_data.h"
#include "server/storage/sqlite/sqlite_storage.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;

TEST(Service, DemoDataGoesThroughTheNormalPathAndRoutesAnswer) {
  const fs::path db =
      fs::temp_directory_path() / ("km-service-" + std::to_string(::getpid()) + ".db");
  fs::remove(db);
  {
    Service svc(std::make_unique<SqliteStorage>(db.string()), {});
    RegisterBuiltinKinds(svc.measurements());
    const auto files = DemoDbbFiles();
    ASSERT_GE(files.size(), 6u);
    for (const auto& f : files)
      EXPECT_TRUE(svc.measurements().Upload(f.bytes, f.name).created) << f.name;
    const auto machines = svc.storage().ListMachines();
    ASSERT_EQ(machines.size(), 1u);
    EXPECT_EQ(machines[0].measurement_count, static_cast<std::int64_t>(files.size()));
    // Demo traces carry a visible error: circularity of several µm, CW and CCW differ.
    const auto r1 = svc.measurements().Results(MeasurementId(1)),
               r2 = svc.measurements().Results(MeasurementId(2));
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

    // The polar plot at a fixed scale; one of the two scale keys alone is refused by name.
    api::Request plot;
    plot.method = "GET";
    plot.path = "/api/v1/measurements/1/plot.png";
    plot.headers["authorization"] = "Bearer boot";
    plot.query = {{"um_per_div", "2"}, {"divisions", "3"}};
    const auto png = router.Dispatch(plot);
    EXPECT_EQ(png.status, 200);
    EXPECT_EQ(png.content_type, "image/png");
    EXPECT_EQ(png.body.substr(1, 3), "PNG");
    plot.query = {{"um_per_div", "2"}};
    const auto half = router.Dispatch(plot);
    EXPECT_EQ(half.status, 400);
    EXPECT_NE(half.body.find("\"field\":\"divisions\""), std::string::npos) << half.body;

    // The demo stream: 30 s of a capacitance sensor and the X encoder, one lost frame, and the
    // straightness profile made from it finds the injected 55 mm waviness and 10 mm lead.
    const auto stream = LoadDemoStream(svc.streams());
    const auto sj = svc.streams().StreamJson(stream);
    ASSERT_EQ(sj["channels"].size(), 2u);
    EXPECT_EQ(sj["gap_count"], 1);
    EXPECT_EQ(sj["missing"], 200);
    EXPECT_EQ(sj["channels"][1]["samples"], 60000);
    MeasurementFilter straightness;
    straightness.kind = "straightness";
    const auto profiles = svc.storage().ListMeasurements(straightness);
    ASSERT_EQ(profiles.items.size(), 1u);
    const auto pr = svc.measurements().Results(profiles.items[0].id);
    ASSERT_GE(pr["periodic"].size(), 2u) << pr.dump();
    EXPECT_NEAR(pr["periodic"][0]["period_mm"].get<double>(), 55.0, 55.0 * 0.02);
    EXPECT_NEAR(pr["periodic"][0]["amplitude_um"].get<double>(), 0.2, 0.01);
    EXPECT_NEAR(pr["periodic"][1]["period_mm"].get<double>(), 10.0, 10.0 * 0.02);
    EXPECT_NEAR(pr["periodic"][1]["amplitude_um"].get<double>(), 0.05, 0.005);
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

// A DBB file of one turn (1° steps): centre offset, an ellipse of `ellipse` µm, a small ripple.
std::string DbbText(const std::string& direction, const std::string& timestamp, double ellipse) {
  std::string t =
      "# format: kinemetric-dbb/1\n# machine_id: pair-vmc\n# test_id: xy\n# direction: " +
      direction +
      "\n# bar_length_mm: 150\n# centre_mm: 0, 0, 0\n# feed_mm_min: 1000\n# timestamp: " +
      timestamp + "\nangle_deg,dr_um\n";
  const double sign = direction == "ccw" ? 1.0 : -1.0;
  for (int i = 0; i < 360; ++i) {
    const double a = sign * i * M_PI / 180.0;
    const double dr = 2.0 * std::cos(a) + ellipse * std::cos(2.0 * a) + 0.2 * std::sin(7.0 * a);
    t += std::to_string(sign * i) + "," + std::to_string(dr) + "\n";
  }
  return t;
}

TEST(Service, APairIsTheOppositeDirectionMeasuredNearestInTime) {
  const fs::path db =
      fs::temp_directory_path() / ("km-service-pair-" + std::to_string(::getpid()) + ".db");
  fs::remove(db);
  {
    Service svc(std::make_unique<SqliteStorage>(db.string()), {});
    RegisterBuiltinKinds(svc.measurements());
    // June CCW + CW, November CCW + CW, then a June CW repeat uploaded last.
    const auto june_ccw =
        svc.measurements().Upload(DbbText("ccw", "2026-06-01T08:00:00Z", 2.0), "a").id;
    const auto june_cw =
        svc.measurements().Upload(DbbText("cw", "2026-06-01T08:05:00Z", 2.1), "b").id;
    const auto nov_ccw =
        svc.measurements().Upload(DbbText("ccw", "2026-11-01T08:00:00Z", 2.2), "c").id;
    const auto nov_cw =
        svc.measurements().Upload(DbbText("cw", "2026-11-01T08:05:00Z", 2.3), "d").id;
    EXPECT_EQ(svc.DbbPairJson(june_ccw)["partner_id"], nlohmann::json(june_cw));
    // Stored as near to the November CCW as the June CW is: the time decides, not the id.
    EXPECT_EQ(svc.DbbPairJson(june_cw)["partner_id"], nlohmann::json(june_ccw));
    EXPECT_EQ(svc.DbbPairJson(nov_ccw)["partner_id"], nlohmann::json(nov_cw));
    EXPECT_EQ(svc.DbbPairJson(nov_cw)["partner_id"], nlohmann::json(nov_ccw));
    // A later upload of a June CW at 07:58: nearer in time to the June CCW than 08:05 is.
    const auto june_cw2 =
        svc.measurements().Upload(DbbText("cw", "2026-06-01T07:58:00Z", 2.4), "e").id;
    EXPECT_EQ(svc.DbbPairJson(june_ccw)["partner_id"], nlohmann::json(june_cw2));
    EXPECT_EQ(svc.DbbPairJson(nov_ccw)["partner_id"], nlohmann::json(nov_cw));
    // Each list item carries the key result of its kind.
    MeasurementFilter f;
    f.machine_id = "pair-vmc";
    f.order = MeasurementFilter::Order::kNewest;
    const auto list = svc.measurements().ListMeasurements(f);
    ASSERT_EQ(list["items"].size(), 5u);
    EXPECT_EQ(list["items"][0]["id"], nlohmann::json(nov_cw));
    EXPECT_EQ(list["items"][0]["key_result"]["name"], "circularity_um");
    EXPECT_EQ(list["items"][0]["key_result"]["value"],
              svc.measurements().Results(nov_cw)["circularity_um"]);
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

// Profiles of a reversal pair: a = M + S, b = M − S (the artefact turned over, the sensor stays).
std::string ReversalText(const char* setup, const char* timestamp, double scale) {
  std::string t =
      "# format: kinemetric-straightness/1\n# machine_id: rev-vmc\n# axis: X\n"
      "# error_direction: Y\n# sensor: indicator\n# reference: straightedge\n"
      "# reversal: " +
      std::string(setup) + "\n# pair_id: x-y\n# timestamp: " + timestamp +
      "\nposition_mm,deviation_um\n";
  const double sign = std::string(setup) == "a" ? 1.0 : -1.0;
  for (int i = 0; i <= 30; ++i) {
    const double x = 10.0 * i;
    const double m = scale * std::sin(2.0 * M_PI * x / 300.0);
    const double a = 1e-4 * (x - 150.0) * (x - 150.0);
    t += std::to_string(x) + "," + std::to_string(m + sign * a) + "\n";
  }
  return t;
}

// Range of the residuals of M about its least-squares line (the independent figure).
double LsqStraightness(double scale) {
  std::vector<double> x, y;
  for (int i = 0; i <= 30; ++i) {
    x.push_back(10.0 * i);
    y.push_back(scale * std::sin(2.0 * M_PI * x.back() / 300.0));
  }
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  const double b = (n * sxy - sx * sy) / (n * sxx - sx * sx), a = (sy - b * sx) / n;
  double lo = 1e300, hi = -1e300;
  for (std::size_t i = 0; i < x.size(); ++i) {
    lo = std::min(lo, y[i] - a - b * x[i]);
    hi = std::max(hi, y[i] - a - b * x[i]);
  }
  return hi - lo;
}

TEST(Service, StraightnessReversalPairsTheStoredSetUps) {
  const fs::path db =
      fs::temp_directory_path() / ("km-service-rev-" + std::to_string(::getpid()) + ".db");
  fs::remove(db);
  {
    Service svc(std::make_unique<SqliteStorage>(db.string()), {});
    RegisterBuiltinKinds(svc.measurements());
    const auto a_id =
        svc.measurements().Upload(ReversalText("a", "2026-11-03T09:00:00Z", 3.0), "a.txt").id;
    EXPECT_THROW(
        {
          if (svc.measurements().StraightnessReversalJson(a_id).is_null())
            throw NotFound("no partner yet");
        },
        NotFound);
    const auto b_id =
        svc.measurements().Upload(ReversalText("b", "2026-11-03T09:20:00Z", 3.0), "b.txt").id;
    // A later pair of the same pair_id (a repair, months later) is not mixed in.
    const auto later_a =
        svc.measurements().Upload(ReversalText("a", "2027-02-01T09:00:00Z", 1.0), "c.txt").id;
    const auto later_b =
        svc.measurements().Upload(ReversalText("b", "2027-02-01T09:20:00Z", 1.0), "d.txt").id;
    for (auto [id, partner, scale] : {std::tuple{a_id, b_id, 3.0}, std::tuple{b_id, a_id, 3.0},
                                      std::tuple{later_a, later_b, 1.0}}) {
      const auto j = svc.measurements().StraightnessReversalJson(id);
      EXPECT_EQ(j["partner_id"], nlohmann::json(partner));
      ASSERT_TRUE(j["reversal"].is_object()) << j.dump();
      EXPECT_NEAR(j["reversal"]["machine_straightness_lsq_um"].get<double>(),
                  LsqStraightness(scale), 2e-5);
    }
    // A profile that is not part of a reversal pair is refused, naming the key.
    std::string plain = ReversalText("a", "2026-11-04T09:00:00Z", 1.0);
    plain.erase(plain.find("# reversal: a\n"), 14);
    plain.erase(plain.find("# pair_id: x-y\n"), 15);
    const auto plain_id = svc.measurements().Upload(plain, "plain.txt").id;
    try {
      svc.measurements().StraightnessReversalJson(plain_id);
      FAIL() << "not refused";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "reversal");
    }
  }
  for (const char* ext : {"", "-wal", "-shm"}) fs::remove(db.string() + ext);
}

}  // namespace
}  // namespace km::server
