// The servo routes (api/servo_routes.cpp → server/servo/servo_service.h) on a service
// holding the pm600-like model and the servo records of the jig plan: identify (and save as the
// next model version), joints with health levels, the force of one record; bad requests named.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "api/routes.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/api/routed_service.h"
#include "tests/unit/servo/servo_truth.h"

namespace km::api {
namespace {

using nlohmann::json;

class ServoRoutes : public test::RoutedServiceTest {
 protected:
  void SetUp() override {
    RoutedServiceTest::SetUp();
    std::ifstream in("data/machines/pm600-like.json");
    std::stringstream machine;
    machine << in.rdbuf();
    svc_->models().StoreMachineModel(machine.str(), "upload", "");
  }
  std::vector<std::int64_t> Upload(const servo::truth::Machine& m, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<std::int64_t> ids;
    for (auto c : servo::truth::JigPlan(240)) {
      for (bool ccw : {true, false}) {
        c.ccw = ccw;
        const auto text = servo::truth::ServoText(c, servo::truth::Simulate(m, c, 2.0, rng));
        ids.push_back(
            svc_->measurements().Upload(text, c.test_id + (ccw ? "_ccw" : "_cw")).id.value());
      }
    }
    return ids;
  }
  Response Call(const std::string& method, const std::string& path, const std::string& body) {
    Request r;
    r.method = method;
    r.path = path;
    r.body = body;
    return router_.Dispatch(r);
  }
};

TEST_F(ServoRoutes, IdentifySaveJointsAndForce) {
  auto m = servo::truth::Pm600Truth();
  m.leg_factor[1] = 3.0;
  const auto ids = Upload(m, 7);
  json body = {{"machine_id", "pm600-like"}, {"measurement_ids", ids}, {"save", true}};
  auto r = Call("POST", "/api/v1/servo/identify", body.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  auto j = json::parse(r.body);
  EXPECT_NEAR(j["identified"]["platform_mass_kg"].get<double>(), m.m_platform, 5.0);
  EXPECT_EQ(j["saved"]["version"], 2);
  EXPECT_EQ(svc_->models().GetMachineModel("pm600-like").version, 2);

  body = {{"machine_id", "pm600-like"}, {"machine_version", 1}, {"measurement_ids", ids}};
  r = Call("POST", "/api/v1/servo/joints", body.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  j = json::parse(r.body);
  EXPECT_EQ(j["level"], 3);
  EXPECT_EQ(j["legs"][1]["level"], 3) << j["legs"][1]["evidence"];
  EXPECT_EQ(j["legs"][0]["level"], 1) << j["legs"][0]["evidence"];
  EXPECT_EQ(j["measurement_ids"], json(ids));

  // The estimate is kept: the machine's history holds it once, asked for twice.
  r = Call("POST", "/api/v1/servo/joints", body.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  r = Call("GET", "/api/v1/machines/pm600-like/joint-health", "");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto history = json::parse(r.body);
  ASSERT_EQ(history["estimates"].size(), 1u) << r.body;
  const auto& e = history["estimates"][0];
  EXPECT_EQ(e["measurement_ids"], json(ids));
  EXPECT_EQ(e["machine_version"], 1);
  EXPECT_EQ(e["level"], 3);
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(e["legs"][k]["level"], j["legs"][k]["level"]) << k;
    EXPECT_EQ(e["legs"][k]["resistance_Nm"], j["legs"][k]["resistance_Nm"]) << k;
    EXPECT_EQ(history["limits"]["reference_Nm"][k], j["legs"][k]["reference_Nm"]) << k;
  }
  EXPECT_EQ(history["limits"]["level2_ratio"], 1.5);
  EXPECT_EQ(history["limits"]["level3_ratio"], 2.5);
  // The records' own results are still what GET …/results answers.
  EXPECT_EQ(svc_->measurements().Results(server::MeasurementId(ids[0]))["record"], "hexapod");
  r = Call("GET", "/api/v1/machines/no-such-machine/joint-health", "");
  EXPECT_EQ(r.status, 404) << r.body;

  r = Call("GET", "/api/v1/measurements/" + std::to_string(ids[0]) + "/servo/force", "");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto force = json::parse(r.body);
  EXPECT_EQ(force["force_N"].size(), 240u);
  ASSERT_EQ(force["strut_force_N"].size(), 240u);
  ASSERT_EQ(force["strut_model_N"].size(), 240u);
  // Without an external load the model carries the motor force: what is left, projected on the
  // tool tip, is the estimated force (eq. 3.3), small against the strut loads.
  double load = 0.0, left = 0.0;
  for (std::size_t i = 0; i < 240; ++i) {
    for (std::size_t k = 0; k < 6; ++k) {
      const double f = force["strut_force_N"][i][k].get<double>();
      load += f * f;
      const double d = f - force["strut_model_N"][i][k].get<double>();
      left += d * d;
    }
  }
  EXPECT_LT(std::sqrt(left / load), 0.1) << std::sqrt(load / 1440) << " N rms";
}

TEST_F(ServoRoutes, AStreamBecomesAFeedDriveRecord) {
  const auto stream = svc_->streams().CreateStream(
      {{"machine_id", "vmc-3axis"},
       {"channels", json::array({{{"channel", 1}}, {{"channel", 2}}})}});
  // X strokes 0 → 100 → 0 mm at 20 mm/s sampled every 10 ms: the encoder in µm on channel 1, the
  // drive force (Coulomb 30 N on an offset of 12 N) on channel 2, its samples 5 ms later.
  std::string body;
  const std::int64_t t0 = 1'700'000'000'000'000;
  for (int k = 0; k < 1000; ++k) {
    const double t = 0.01 * k, x = 20.0 * (t < 5.0 ? t : 10.0 - t);
    const double f = 12.0 + (t < 5.0 ? 30.0 : -30.0);
    body += json{{"channel", 1}, {"counter", k}, {"t_us", t0 + 10'000 * k}, {"value_um", 1e3 * x}}
                .dump() +
            "\n";
    body += json{{"channel", 2}, {"counter", k}, {"t_us", t0 + 10'000 * k + 5'000}, {"value_um", f}}
                .dump() +
            "\n";
  }
  svc_->streams().IngestFrames(
      stream, "application/x-ndjson",
      [&](const std::function<bool(std::string_view)>& sink) { return sink(body); });
  const json request = {
      {"axes", json::array({{{"axis", "X"}, {"position_channel", 1}, {"force_channel", 2}}})},
      {"test_id", "x-strokes"}};
  auto r = Call("POST", "/api/v1/streams/" + to_string(stream) + "/servo", request.dump());
  ASSERT_EQ(r.status, 201) << r.body;
  const auto id = json::parse(r.body)["id"].get<server::MeasurementId>();
  const auto result = svc_->measurements().Results(id);
  EXPECT_EQ(result["record"], "feed_drive");
  EXPECT_NEAR(result["axes"][0]["stroke_mm"].get<double>(), 100.0, 0.5);
  EXPECT_NEAR(result["axes"][0]["force_max_N"].get<double>(), 42.0, 1e-6);
  EXPECT_EQ(svc_->storage().GetMeasurement(id)->machine_id, "vmc-3axis");
  r = Call("POST", "/api/v1/streams/" + to_string(stream) + "/servo",
           json{{"axes", json::array({{{"axis", "X"}, {"position_channel", 1}}})}}.dump());
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("force_channel"), std::string::npos) << r.body;
}

TEST_F(ServoRoutes, AStreamOfStrutLoadsBecomesAHexapodRecord) {
  const auto stream = svc_->streams().CreateStream({{"machine_id", "pm600-like"}});
  std::mt19937 rng(9);
  auto c = servo::truth::JigPlan(120)[6];  // tilted cone test
  const auto rec = servo::truth::Simulate(servo::truth::Pm600Truth(), c, 2.0, rng);
  // Channels 1–6: x, y, z in µm and A, B, C in millidegrees; 7–12: the strut forces in N.
  std::string body;
  const std::int64_t t0 = 1'700'000'000'000'000;
  for (std::size_t i = 0; i < rec.t_s.size(); ++i) {
    const auto t = t0 + static_cast<std::int64_t>(std::llround(rec.t_s[i] * 1e6));
    const double v[12] = {1e3 * rec.tip_mm[i].x(), 1e3 * rec.tip_mm[i].y(), 1e3 * rec.tip_mm[i].z(),
                          1e3 * c.tilt_deg.x(),    1e3 * c.tilt_deg.y(),    1e3 * c.tilt_deg.z(),
                          rec.force_N[i][0],       rec.force_N[i][1],       rec.force_N[i][2],
                          rec.force_N[i][3],       rec.force_N[i][4],       rec.force_N[i][5]};
    for (int ch = 0; ch < 12; ++ch) {
      body +=
          json{{"channel", ch + 1}, {"counter", i}, {"t_us", t}, {"value_um", v[ch]}}.dump() + "\n";
    }
  }
  svc_->streams().IngestFrames(
      stream, "application/x-ndjson",
      [&](const std::function<bool(std::string_view)>& sink) { return sink(body); });
  const json request = {{"struts",
                         {{"pose_channels", {1, 2, 3, 4, 5, 6}},
                          {"force_channels", {7, 8, 9, 10, 11, 12}},
                          {"tool_length_mm", c.tool_mm},
                          {"motion", "circle"},
                          {"direction", "ccw"}}},
                        {"test_id", "g"}};
  auto r = Call("POST", "/api/v1/streams/" + to_string(stream) + "/servo", request.dump());
  ASSERT_EQ(r.status, 201) << r.body;
  const auto id = json::parse(r.body)["id"].get<server::MeasurementId>();
  const auto result = svc_->measurements().Results(id);
  EXPECT_EQ(result["record"], "hexapod");
  EXPECT_EQ(result["samples"], 120);
  double fmax = -1e300;
  for (const auto& f : rec.force_N) fmax = std::max(fmax, f[2]);
  EXPECT_NEAR(result["force_max_N"][2].get<double>(), fmax, 1e-6);
  EXPECT_EQ(svc_->storage().GetMeasurement(id)->direction, "ccw");
  // The force of the stored record with the machine's model: no load, small forces.
  r = Call("GET", "/api/v1/measurements/" + to_string(id) + "/servo/force", "");
  ASSERT_EQ(r.status, 200) << r.body;
  const json force = json::parse(r.body);  // kept alive over the loop
  for (const auto& v : force["mean_force_N"]) EXPECT_LT(std::abs(v.get<double>()), 20.0);
  r = Call("POST", "/api/v1/streams/" + to_string(stream) + "/servo",
           json{{"struts", {{"pose_channels", {1, 2, 3}}}}}.dump());
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("struts.pose_channels"), std::string::npos) << r.body;
}

TEST_F(ServoRoutes, BadRequestsAreNamed) {
  const auto ids = Upload(servo::truth::Pm600Truth(), 8);
  auto r = Call("POST", "/api/v1/servo/joints", json{{"machine_id", "pm600-like"}}.dump());
  EXPECT_EQ(r.status, 400);
  EXPECT_NE(r.body.find("measurement_ids"), std::string::npos) << r.body;
  r = Call("POST", "/api/v1/servo/identify",
           json{{"machine_id", "other"}, {"measurement_ids", ids}}.dump());
  EXPECT_EQ(r.status, 404) << r.body;
  r = Call("POST", "/api/v1/servo/joints",
           json{{"machine_id", "pm600-like"}, {"measurement_ids", {ids[0], ids[0]}}}.dump());
  EXPECT_EQ(r.status, 400) << r.body;
  r = Call("POST", "/api/v1/servo/joints",
           json{{"machine_id", "pm600-like"}, {"measurement_ids", {ids[0]}}}.dump());
  EXPECT_EQ(r.status, 400) << r.body;  // no CW/CCW pair
  r = Call("GET", "/api/v1/measurements/999999/servo/force", "");
  EXPECT_EQ(r.status, 404) << r.body;
}

// An upload of a feed-drive record whose position jumps 100 mm within 2 ms (two recordings
// joined) is refused with 400, naming the file, the line after the jump and the jump; nothing
// is stored.
TEST_F(ServoRoutes, AJoinedFeedDriveUploadIsRefusedNamingTheJump) {
  std::string text =
      "# format: kinemetric-servo/1\n# machine_id: vmc\n# test_id: joined\n# motion: path\n"
      "# axis: X\n# force_unit: N\nt_s,pos_mm,force\n";  // rows from line 8
  char buf[96];
  for (int i = 0; i < 60; ++i) {
    std::snprintf(buf, sizeof buf, "%.3f,%.4f,31.5\n", 0.002 * i,
                  0.08 * i + (i >= 30 ? 100.0 : 0.0));
    text += buf;
  }
  Request req;
  req.method = "POST";
  req.path = "/api/v1/measurements";
  req.headers["x-filename"] = "joined.txt";
  req.body = text;
  const Response r = router_.Dispatch(req);
  EXPECT_EQ(r.status, 400) << r.body;
  const json problem = json::parse(r.body);
  EXPECT_EQ(problem["file"], "joined.txt") << r.body;
  EXPECT_EQ(problem["line"], 38) << r.body;
  EXPECT_EQ(problem["field"], "pos_mm") << r.body;
  EXPECT_NE(problem["reason"].get<std::string>().find("jumps by 100.080 mm in 2.000 ms"),
            std::string::npos)
      << r.body;
  EXPECT_EQ(Call("GET", "/api/v1/measurements", "").body.find("joined"), std::string::npos);
}

}  // namespace
}  // namespace km::api
