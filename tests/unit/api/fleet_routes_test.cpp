// The fleet overview and trend routes (api/fleet_routes.cpp → server/audits/fleet_service.h) on a
// service holding the example DBB tests and flatness grid of vmc-3axis: each machine's newest
// measurement, count, open jobs and newest audit; a trend's points are the stored figures, oldest
// first (the centre offset as the length of the stored vector); bad requests named.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "api/routes.h"
#include "server/audits/accuracy_audit.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/api/routed_service.h"

namespace km::api {
namespace {

using nlohmann::json;

std::string Example(const std::string& name) {
  std::ifstream in("data/examples/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string Replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

class FleetRoutes : public test::RoutedServiceTest {
 protected:
  // The jobs stored by hand below are counted as open: no worker may take (and fail) them.
  server::ServiceOptions Options() const override {
    server::ServiceOptions o;
    o.jobs.workers = 0;
    return o;
  }
  json Get(const std::string& path, const std::string& metric = "", int status = 200) {
    Request r;
    r.method = "GET";
    r.path = path;
    if (!metric.empty()) r.query.emplace("metric", metric);
    const auto out = router_.Dispatch(r);
    EXPECT_EQ(out.status, status) << path << " " << metric << ": " << out.body;
    return json::parse(out.body);
  }
};

TEST_F(FleetRoutes, NewestMeasurementOpenJobsAndTrends) {
  // The CW test measured a month before the CCW one (uploaded after it).
  const auto ccw = svc_->measurements().Upload(Example("dbb_xy-r150_ccw.txt"), "ccw.txt").id;
  const auto cw = svc_->measurements()
                      .Upload(Replaced(Example("dbb_xy-r150_cw.txt"), "2026-11-02T07:58:00Z",
                                       "2026-10-02T07:58:00Z"),
                              "cw.txt")
                      .id;
  const auto flat = svc_->measurements().Upload(Example("flatness_table.txt"), "flat.txt").id;
  svc_->storage().CreateJob("calibration", json{{"machine_id", "vmc-3axis"}}.dump());
  svc_->storage().CreateJob("discovery", json{{"measurement_ids", {cw}}}.dump());
  svc_->storage().CreateJob("calibration", json{{"machine_id", "other"}}.dump());

  const auto fleet = Get("/api/v1/fleet");
  ASSERT_EQ(fleet["machines"].size(), 1u) << fleet.dump();
  const auto& m = fleet["machines"][0];
  EXPECT_EQ(m["machine_id"], "vmc-3axis");
  EXPECT_EQ(m["measurements"], 3);
  EXPECT_EQ(m["last_measurement"]["id"], json(flat));  // 2026-11-03, the newest measured
  EXPECT_EQ(m["last_measurement"]["kind"], "flatness");
  EXPECT_EQ(m["last_measurement"]["measured_at"], "2026-11-03T10:00:00Z");
  EXPECT_EQ(m["open_jobs"], 2);
  EXPECT_TRUE(m["audit"].is_null());
  // The newest accuracy audit of the machine.
  server::AuditVerdictRecord v;
  v.machine_id = "vmc-3axis";
  v.level = 3;
  v.trigger = "manual";
  v.created_at = "2026-11-04T09:00:00Z";
  v.verdict_json = "{}";
  const auto newest = svc_->storage().AddAuditVerdict(v);
  v.level = 1;
  v.created_at = "2026-11-01T09:00:00Z";
  svc_->storage().AddAuditVerdict(v);
  const auto audit = Get("/api/v1/fleet")["machines"][0]["audit"];
  EXPECT_EQ(audit, (json{{"id", newest}, {"level", 3}, {"created_at", "2026-11-04T09:00:00Z"}}));

  auto t = Get("/api/v1/machines/vmc-3axis/trends", "circularity_um");
  ASSERT_EQ(t["points"].size(), 2u);
  EXPECT_EQ(t["points"][0]["measurement_id"], nlohmann::json(cw));
  EXPECT_EQ(t["points"][0]["measured_at"], "2026-10-02T07:58:00Z");
  EXPECT_EQ(t["points"][0]["value"], svc_->measurements().Results(cw)["circularity_um"]);
  EXPECT_EQ(t["points"][1]["measurement_id"], nlohmann::json(ccw));
  EXPECT_EQ(t["points"][1]["value"], svc_->measurements().Results(ccw)["circularity_um"]);
  t = Get("/api/v1/machines/vmc-3axis/trends", "centre_offset_um");
  const auto c = svc_->measurements().Results(ccw)["centre_offset_um"];
  EXPECT_DOUBLE_EQ(t["points"][1]["value"].get<double>(),
                   std::hypot(c[0].get<double>(), c[1].get<double>()));
  t = Get("/api/v1/machines/vmc-3axis/trends", "circular_deviation_um");
  EXPECT_EQ(t["points"][1]["value"],
            svc_->measurements().Results(ccw)["iso230_4"]["circular_deviation_um"]);
  t = Get("/api/v1/machines/vmc-3axis/trends", "flatness_min_zone_um");
  ASSERT_EQ(t["points"].size(), 1u);
  EXPECT_EQ(t["points"][0]["value"], svc_->measurements().Results(flat)["flatness_min_zone_um"]);
  // A figure of the CW/CCW pair: each test with its partner.
  t = Get("/api/v1/machines/vmc-3axis/trends", "circular_hysteresis_um");
  ASSERT_EQ(t["points"].size(), 2u);
  EXPECT_EQ(t["points"][0]["value"], svc_->DbbPairJson(cw)["pair"]["circular_hysteresis_um"]);
  EXPECT_EQ(t["unit"], "µm");
  EXPECT_EQ(Get("/api/v1/machines/vmc-3axis/trends")["metrics"].size(),
            server::AuditMetrics().size() - 1);

  EXPECT_EQ(Get("/api/v1/machines/vmc-3axis/trends", "nonsense", 400)["field"], "metric");
  Get("/api/v1/machines/no-such/trends", "circularity_um", 404);
}

}  // namespace
}  // namespace km::api
