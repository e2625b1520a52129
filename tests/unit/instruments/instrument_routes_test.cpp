// The instrument register through the route table with tokens and the audit log (api/routes.cpp,
// api/instrument_routes.cpp) and its use at upload: a viewer or an operator may read but not
// store an instrument (403), an engineer stores versions, bad bodies and serials are 400 naming
// the field; a DBB file naming a registered serial takes the register's uncertainties where it
// states none, its result names the source of each and the register version, a measurement
// after the calibration was due carries a warning; the stored file is never changed; hostile
// serials and bodies are refused, never a 500.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <sstream>

#include "tests/unit/api/token_routes.h"
#include "tests/unit/server/pdf_text.h"

namespace km::api {
namespace {

using nlohmann::json;

class InstrumentRoutes : public test::TokenRoutesTest {
 protected:
  void SetUp() override {
    TokenRoutesTest::SetUp();
    viewer_ = Token("viewer");
    operator_ = Token("operator");
    engineer_ = Token("engineer");
  }
  Response Put(const std::string& serial, const json& body, const std::string& token = "") {
    return Call("PUT", "/api/v1/instruments/" + serial, token.empty() ? engineer_ : token,
                body.dump());
  }
  // Uploads a file as an operator; its own stored result.
  json Upload(const std::string& bytes, server::MeasurementId* id = nullptr) {
    const auto r = Call("POST", "/api/v1/measurements", operator_, bytes);
    EXPECT_EQ(r.status, 201) << r.body;
    const auto stored = json::parse(r.body)["id"].get<server::MeasurementId>();
    if (id) *id = stored;
    return json::parse(
        Call("GET", "/api/v1/measurements/" + to_string(stored) + "/results", viewer_).body);
  }
  std::string viewer_, operator_, engineer_;
};

// An example file without its own `instrument` line (the positioning example names its laser).
std::string Example(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::string out, line;
  while (std::getline(in, line)) {
    if (line.rfind("# instrument:", 0) != 0) out += line + "\n";
  }
  return out;
}

std::string WithHeader(const std::string& file, const std::string& lines) {
  const auto nl = file.find('\n');
  return file.substr(0, nl + 1) + lines + file.substr(nl + 1);
}

// A ballbar calibrated on 2026-01-15, due again after 365 days (2027-01-15); the example DBB
// tests were measured on 2026-11-02.
json Ballbar() {
  return {{"instrument", "Renishaw QC20-W"},
          {"kind", "ballbar"},
          {"uncertainties",
           {{"u_reading_um", 0.5}, {"u_bar_length_um", 0.7}, {"bar_expansion_ppm_per_k", 11.5}}},
          {"calibrated", "2026-01-15"},
          {"calibration_interval_days", 365},
          {"certificate", "UKAS 0123 / 2026-004"}};
}

TEST_F(InstrumentRoutes, RolesVersionsListAndErrors) {
  EXPECT_EQ(Call("GET", "/api/v1/instruments/QC20-7", viewer_).status, 404);
  EXPECT_EQ(Put("QC20-7", Ballbar(), viewer_).status, 403);
  EXPECT_EQ(Put("QC20-7", Ballbar(), operator_).status, 403);
  const auto v1 = Put("QC20-7", Ballbar());
  ASSERT_EQ(v1.status, 200) << v1.body;
  const json j1 = json::parse(v1.body);
  EXPECT_EQ(j1["version"], 1);
  EXPECT_EQ(j1["created"], true);
  EXPECT_EQ(j1["serial"], "QC20-7");
  EXPECT_EQ(j1["calibration_due"], "2027-01-15");
  EXPECT_EQ(j1["uncertainties"]["u_bar_length_um"], 0.7);
  EXPECT_EQ(json::parse(Put("QC20-7", Ballbar()).body)["created"], false);
  json v2 = Ballbar();
  v2["uncertainties"]["u_reading_um"] = 0.4;
  EXPECT_EQ(json::parse(Put("QC20-7", v2, "boot").body)["version"], 2);  // admin too
  EXPECT_EQ(json::parse(Call("GET", "/api/v1/instruments/QC20-7", viewer_).body)["version"], 2);
  Request r1;
  r1.method = "GET";
  r1.path = "/api/v1/instruments/QC20-7";
  r1.query.emplace("version", "1");
  r1.headers["authorization"] = "Bearer " + viewer_;
  EXPECT_EQ(json::parse(router_.Dispatch(r1).body)["uncertainties"]["u_reading_um"], 0.5);
  r1.query.clear();
  r1.query.emplace("version", "9");
  EXPECT_EQ(router_.Dispatch(r1).status, 404);
  ASSERT_EQ(Put("XL80-1", {{"instrument", "Renishaw XL-80"}, {"kind", "laser"}}).status, 200);
  const auto list = json::parse(Call("GET", "/api/v1/instruments", viewer_).body);
  EXPECT_EQ(list["total"], 2);
  EXPECT_EQ(list["items"][0]["serial"], "QC20-7");
  EXPECT_EQ(list["items"][0]["version"], 2);
  EXPECT_EQ(list["items"][1]["serial"], "XL80-1");
  // Refusals name the field.
  json bad = Ballbar();
  bad["uncertainties"]["u_colour"] = 1;
  const auto r400 = Put("QC20-7", bad);
  EXPECT_EQ(r400.status, 400);
  EXPECT_EQ(r400.content_type, "application/problem+json");
  EXPECT_EQ(json::parse(r400.body).value("field", ""), "uncertainties.u_colour") << r400.body;
  bad = Ballbar();
  bad["calibrated"] = "2026-02-30";
  EXPECT_EQ(json::parse(Put("QC20-7", bad).body).value("field", ""), "calibrated");
  bad = Ballbar();
  bad["owner"] = "lab";
  EXPECT_EQ(json::parse(Put("QC20-7", bad).body).value("field", ""), "owner");
  const auto bad_serial = Put("=cmd", Ballbar());
  EXPECT_EQ(bad_serial.status, 400);
  EXPECT_EQ(json::parse(bad_serial.body).value("field", ""), "serial");
  // Every PUT is in the audit log, naming the instrument.
  const auto log = json::parse(Call("GET", "/api/v1/audit-log", "boot").body)["items"];
  bool named = false;
  for (const auto& e : log)
    named = named || (e["method"] == "PUT" && e["subject"] == "instrument QC20-7");
  EXPECT_TRUE(named) << log.dump();
}

TEST_F(InstrumentRoutes, AnUploadNamingARegisteredSerialTakesItsValues) {
  ASSERT_EQ(Put("QC20-7", Ballbar()).status, 200);
  // The file states its own u_reading_um; the bar's uncertainties come from the register.
  const std::string bytes = WithHeader(Example("dbb_xy-r150_cw.txt"),
                                       "# instrument_serial: QC20-7\n# u_reading_um: 0.3\n");
  server::MeasurementId id;
  const json result = Upload(bytes, &id);
  const json& b = result["instrument"];
  ASSERT_TRUE(b.is_object()) << result.dump();
  EXPECT_EQ(b["instrument"], "Renishaw QC20-W");
  EXPECT_EQ(b["serial"], "QC20-7");
  EXPECT_EQ(b["calibrated"], "2026-01-15");
  EXPECT_EQ(b["certificate"], "UKAS 0123 / 2026-004");
  EXPECT_EQ(b["register_version"], 1);
  EXPECT_EQ(b["sources"], json({{"u_reading_um", "file"},
                                {"u_bar_length_um", "register"},
                                {"bar_expansion_ppm_per_k", "register"}}));
  EXPECT_EQ(b["calibration_due"], "2027-01-15");
  EXPECT_EQ(b["overdue"], false);
  for (const auto& w : result.value("warnings", json::array())) {
    EXPECT_EQ(w.get<std::string>().find("calibration interval"), std::string::npos) << w;
  }
  // The stored file and its metadata are the file's own.
  EXPECT_EQ(svc_->storage().GetRaw(id), bytes);
  const auto one = json::parse(Call("GET", "/api/v1/measurements/" + to_string(id), viewer_).body);
  EXPECT_EQ(one["metadata"]["u_reading_um"], "0.3");
  EXPECT_FALSE(one["metadata"].contains("u_bar_length_um"));
  EXPECT_FALSE(one["metadata"].contains("instrument"));
}

TEST_F(InstrumentRoutes, ThePairAndTheReportUseTheRegisterToo) {
  ASSERT_EQ(Put("QC20-7", Ballbar()).status, 200);
  server::MeasurementId cw, ccw;
  Upload(WithHeader(Example("dbb_xy-r150_cw.txt"), "# instrument_serial: QC20-7\n"), &cw);
  const json own =
      Upload(WithHeader(Example("dbb_xy-r150_ccw.txt"), "# instrument_serial: QC20-7\n"), &ccw);
  EXPECT_GT(own["uncertainty"]["figures"]["average_radial_error_um"]["U_um"].get<double>(), 1.3);
  // The pair is analysed again from the stored bytes: with the register's u_bar_length_um.
  const auto pair = Call("GET", "/api/v1/measurements/" + to_string(ccw) + "/pair", viewer_);
  ASSERT_EQ(pair.status, 200) << pair.body;
  const json p = json::parse(pair.body)["pair"]["uncertainty"];
  bool bar = false;
  for (const auto& in : p["inputs"]) {
    bar = bar || (in["input"] == "u_bar_length_um" && in["stated"] == true && in["u"] == 0.7);
  }
  EXPECT_TRUE(bar) << p.dump();
  EXPECT_GT(p["figures"]["circular_hysteresis_um"]["U_um"].get<double>(), 0.0);
  // The report names the instrument as the register completes it.
  const auto pdf = Call("GET", "/api/v1/measurements/" + to_string(ccw) + "/report.pdf", viewer_);
  ASSERT_EQ(pdf.status, 200);
  const std::string text = ::km::test::PdfToText(pdf.body, Path("r.pdf"));
  EXPECT_NE(text.find("QC20-7"), std::string::npos) << text;
  EXPECT_NE(text.find("2026-01-15"), std::string::npos) << text;
  EXPECT_NE(text.find("register version 1"), std::string::npos) << text;
}

TEST_F(InstrumentRoutes, AMeasurementAfterTheCalibrationWasDueCarriesAWarning) {
  json old = Ballbar();
  old["calibrated"] = "2025-01-15";  // due 2026-01-15, the example was measured on 2026-11-02
  ASSERT_EQ(Put("QC20-7", old).status, 200);
  const json result =
      Upload(WithHeader(Example("dbb_xy-r150_ccw.txt"), "# instrument_serial: QC20-7\n"));
  EXPECT_EQ(result["instrument"]["overdue"], true);
  EXPECT_EQ(result["instrument"]["calibration_due"], "2026-01-15");
  EXPECT_EQ(result["instrument"]["sources"]["u_reading_um"], "register");
  bool warned = false;
  for (const auto& w : result["warnings"]) {
    warned = warned || w == "instrument QC20-7 was past its calibration interval (due "
                            "2026-01-15) when this was measured";
  }
  EXPECT_TRUE(warned) << result.dump();
}

TEST_F(InstrumentRoutes, AnUnregisteredSerialAndAFileWithoutInstrumentKeys) {
  const json unregistered =
      Upload(WithHeader(Example("dbb_xy-r150_cw.txt"),
                        "# instrument: ballbar of the lab\n# instrument_serial: NOT-REGISTERED\n# "
                        "u_reading_um: 1\n"));
  EXPECT_EQ(unregistered["instrument"]["instrument"], "ballbar of the lab");
  EXPECT_EQ(unregistered["instrument"]["serial"], "NOT-REGISTERED");
  EXPECT_TRUE(unregistered["instrument"]["register_version"].is_null());
  EXPECT_TRUE(unregistered["instrument"]["calibration_due"].is_null());
  EXPECT_EQ(unregistered["instrument"]["sources"], json({{"u_reading_um", "file"}}));
  const json none = Upload(Example("flatness_table.txt"));
  ASSERT_TRUE(none.contains("instrument"));
  EXPECT_TRUE(none["instrument"].is_null());
  // Every kind carries the block.
  ASSERT_EQ(Put("XL80-1", {{"instrument", "Renishaw XL-80"},
                           {"kind", "laser"},
                           {"uncertainties", {{"u_laser_ppm", 0.2}, {"u_reading_um", 0.1}}}})
                .status,
            200);
  for (const char* name : {"straightness_x-z.txt", "parallelism_x_t-slot.txt", "positioning_x.txt",
                           "tracker_cube.txt", "servo_x-strokes.txt"}) {
    const json r = Upload(WithHeader(Example(name), "# instrument_serial: XL80-1\n"));
    EXPECT_EQ(r["instrument"]["register_version"], 1) << name;
    EXPECT_EQ(r["instrument"]["instrument"], "Renishaw XL-80") << name;
  }
}

TEST_F(InstrumentRoutes, HostileSerialsAndBodiesAreRefusedNeverA500) {
  const auto refused = [&](const std::string& serial, const std::string& body) {
    const auto put = Call("PUT", "/api/v1/instruments/" + serial, engineer_, body);
    const auto get = Call("GET", "/api/v1/instruments/" + serial, viewer_);
    for (const auto* r : {&put, &get}) {
      EXPECT_TRUE(r->status == 400 || r->status == 404)
          << serial.substr(0, 40) << ": " << r->status;
    }
    return put.status;
  };
  const std::string good = Ballbar().dump();
  for (const std::string& serial :
       {std::string(".."), std::string("..%2Fetc"), std::string("a\r\nSet-Cookie: x"),
        std::string("\"quoted\""), std::string("'q'"), std::string("<img src=x>"),
        std::string(10000, 'S'), std::string("-1"), std::string("a b"), std::string("é")}) {
    EXPECT_EQ(refused(serial, good), 400) << serial.substr(0, 40);
  }
  refused("../../etc/passwd", good);  // another path: no route (404) or refused
  const std::string deep = std::string(10000, '[') + std::string(10000, ']');
  const std::string deep_object = [] {
    std::string s;
    for (int i = 0; i < 10000; ++i) s += "{\"a\":";
    s += "1";
    s += std::string(10000, '}');
    return s;
  }();
  for (
      const std::string& body :
      {deep, deep_object,
       std::string(R"({"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":1e400}})"),
       std::string(R"({"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":NaN}})"),
       std::string(R"({"instrument":"x","kind":"laser","uncertainties":{"u_laser_ppm":1e300}})"),
       std::string(
           R"({"instrument":"x","kind":"laser","calibration_interval_days":99999999999999999999999})"),
       std::string(R"({"instrument":"x","kind":"laser","kind":"ballbar"})"), std::string(""),
       std::string("{"), std::string("null")}) {
    EXPECT_EQ(refused("SAFE-1", body), 400) << body.substr(0, 60);
  }
  // A file whose serial could inject anything is refused at upload, naming the key.
  for (const char* line : {"# instrument_serial: ../x\n", "# instrument_serial: \"<b>\"\n",
                           "# u_reading_um: NaN\n", "# u_bar_length_um: 1e999\n"}) {
    const auto r = Call("POST", "/api/v1/measurements", operator_,
                        WithHeader(Example("dbb_xy-r150_cw.txt"), line));
    EXPECT_EQ(r.status, 400) << line << r.body;
    EXPECT_EQ(json::parse(r.body)["field"].get<std::string>().substr(0, 2),
              std::string(line).substr(2, 2))
        << r.body;
  }
}

}  // namespace
}  // namespace km::api
