// Reports as certificates through the route table with tokens and the audit log
// (api/report_routes.cpp, server/reports/certificates.h): a measurement's PDF names its
// certificate number, revision and approval, its instrument from the register, each figure with
// U, k and the decision under the tolerance table's rule; a viewer may not approve, an engineer
// approves the current revision once (the audit log names the certificate) and every later
// request answers the frozen PDF byte for byte; a changed tolerance table makes a new draft
// revision that names the approved one it supersedes, the approved revision stays readable;
// as-found / as-left is the user's choice of a later test of the same set-up (a laser test with
// both compensation tables), refused naming `as_left` otherwise; job and audit reports are
// certificates too.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <regex>
#include <sstream>

#include "tests/unit/api/token_routes.h"
#include "tests/unit/server/pdf_text.h"

namespace km::api {
namespace {

using nlohmann::json;

class Certificates : public test::TokenRoutesTest {
 protected:
  void SetUp() override {
    TokenRoutesTest::SetUp();
    viewer_ = Token("viewer", "vera");
    operator_ = Token("operator", "otto");
    engineer_ = Token("engineer", "erin");
  }
  std::int64_t Upload(const std::string& bytes) {
    const auto r = Call("POST", "/api/v1/measurements", operator_, bytes);
    EXPECT_EQ(r.status, 201) << r.body;
    return json::parse(r.body)["id"].get<std::int64_t>();
  }
  std::string Pdf(const std::string& path, int status = 200) {
    const auto r = Call("GET", path, viewer_);
    EXPECT_EQ(r.status, status) << path << ": " << r.body;
    return r.body;
  }
  std::string Text(const std::string& pdf) {
    return ::km::test::PdfToText(pdf, Path("report.pdf"));
  }
  void Tolerances(double g_um) {
    const json body{{"tolerances",
                     {{{"kind", "dbb"}, {"metric", "circular_deviation_um"}, {"tolerance", g_um}},
                      {{"kind", "dbb"}, {"metric", "circularity_um"}, {"tolerance", 30}}}},
                    {"decision_rule", "guarded"}};
    const auto r = Call("PUT", "/api/v1/machines/vmc-3axis/tolerances", engineer_, body.dump());
    ASSERT_EQ(r.status, 200) << r.body;
  }
  std::string viewer_, operator_, engineer_;
};

std::string Example(const std::string& name) {
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/" + name);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string WithHeader(const std::string& file, const std::string& lines) {
  const auto nl = file.find('\n');
  return file.substr(0, nl + 1) + lines + file.substr(nl + 1);
}

std::string Replaced(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

// A DBB test of the example set-up naming a registered ballbar and its own reading uncertainty.
std::string Dbb(const std::string& direction, const std::string& timestamp = "") {
  std::string f = WithHeader(Example("dbb_xy-r150_" + direction + ".txt"),
                             "# instrument_serial: QC20-7\n# u_reading_um: 0.3\n");
  if (!timestamp.empty()) f = Replaced(f, "2026-11-02T07:58:00Z", timestamp);
  return f;
}

json Ballbar() {
  return {{"instrument", "Renishaw QC20-W"},
          {"kind", "ballbar"},
          {"uncertainties", {{"u_bar_length_um", 0.7}, {"bar_expansion_ppm_per_k", 11.5}}},
          {"calibrated", "2026-01-15"},
          {"calibration_interval_days", 365},
          {"certificate", "UKAS 0123 / 2026-004"}};
}

// No identifier of a JSON result (snake_case keys such as circular_deviation_um) in the text.
void ExpectNoRawKeys(const std::string& text) {
  std::smatch m;
  EXPECT_FALSE(std::regex_search(text, m, std::regex("[a-z]+_[a-z0-9_]*(um|deg|mm|pct)\\b")))
      << m.str(0);
}

TEST_F(Certificates, ADraftIsApprovedOnceFrozenAndSupersededByARevision) {
  ASSERT_EQ(Call("PUT", "/api/v1/instruments/QC20-7", engineer_, Ballbar().dump()).status, 200);
  Tolerances(15);
  const auto id = Upload(Dbb("ccw"));
  Upload(Dbb("cw"));
  const std::string path = "/api/v1/measurements/" + std::to_string(id) + "/report";
  const std::string number =
      "KM-M" + std::string(6 - std::to_string(id).size(), '0') + std::to_string(id);
  const std::string draft = Text(Pdf(path + ".pdf"));
  EXPECT_NE(draft.find(number + ", revision 1"), std::string::npos) << draft;
  EXPECT_NE(draft.find("draft"), std::string::npos);
  // The instrument line wraps in the identification block: read it with one space between words.
  const std::string flat = std::regex_replace(draft, std::regex("\\s+"), " ");
  EXPECT_NE(flat.find("Renishaw QC20-W (ballbar), serial QC20-7"), std::string::npos) << flat;
  EXPECT_NE(flat.find("calibrated 2026-01-15"), std::string::npos);
  EXPECT_NE(flat.find("UKAS 0123 / 2026-004"), std::string::npos);
  EXPECT_NE(draft.find("Figures with their uncertainty and decision"), std::string::npos);
  // Each figure with its value, U, k and decision: G against 15 µm under the guarded rule.
  EXPECT_TRUE(std::regex_search(
      draft, std::regex("Circular deviation G — CCW +[0-9.]+ +[0-9.]+ +2 +15\\.000 +(pass|fail|"
                        "undecided) +µm")))
      << draft;
  EXPECT_TRUE(std::regex_search(draft, std::regex("Circular hysteresis H — pair +[0-9.]+ +[0-9.]+ "
                                                  "+2 +— +no tolerance")))
      << draft;
  ExpectNoRawKeys(draft);

  // Who may approve, and what an approval answers and records.
  EXPECT_EQ(Call("POST", path + "/approve", viewer_).status, 403);
  EXPECT_EQ(Call("POST", path + "/approve", operator_).status, 403);
  EXPECT_EQ(Call("POST", path + "/approve", engineer_, R"({"revision": 0})").status, 400);
  EXPECT_EQ(Call("POST", path + "/approve", engineer_, R"({"rev": 1})").status, 400);
  EXPECT_EQ(Call("POST", path + "/approve", engineer_, R"({"revision": 2})").status, 409);
  const auto ok = Call("POST", path + "/approve", engineer_, R"({"revision": 1})");
  ASSERT_EQ(ok.status, 200) << ok.body;
  const json a = json::parse(ok.body);
  EXPECT_EQ(a["certificate"], number);
  EXPECT_EQ(a["revision"], 1);
  EXPECT_EQ(a["approved_by"], "erin");
  const std::string at = a["approved_at"].get<std::string>();
  EXPECT_EQ(Call("POST", path + "/approve", engineer_).status, 409);  // already approved
  const json log = json::parse(Call("GET", "/api/v1/audit-log?limit=5", "boot").body);
  bool logged = false;
  for (const auto& e : log["items"]) {
    logged |= e["status"] == 200 && e["token_name"] == "erin" &&
              e["subject"].get<std::string>().find("certificate " + number +
                                                   " revision 1 "
                                                   "approved") != std::string::npos;
  }
  EXPECT_TRUE(logged) << log.dump();

  const std::string frozen = Pdf(path + ".pdf");
  EXPECT_EQ(Pdf(path + ".pdf"), frozen);  // byte for byte, printed once
  const std::string approved = Text(frozen);
  EXPECT_NE(approved.find("approved by erin at " + at), std::string::npos) << approved;
  EXPECT_EQ(approved.find("draft"), std::string::npos);

  // A new tolerance table changes the decision: a new revision, a draft again.
  Tolerances(1);
  const std::string second = Text(Pdf(path + ".pdf"));
  EXPECT_NE(second.find(number + ", revision 2"), std::string::npos) << second;
  EXPECT_NE(second.find("draft"), std::string::npos);
  EXPECT_NE(second.find("revision 1, approved by erin at " + at), std::string::npos);
  EXPECT_EQ(Pdf(path + ".pdf?revision=1"), frozen);
  Pdf(path + ".pdf?revision=3", 404);
  const json revs = json::parse(Call("GET", path + "/revisions", viewer_).body);
  EXPECT_EQ(revs["current_revision"], 2);
  ASSERT_EQ(revs["revisions"].size(), 2u);
  EXPECT_EQ(revs["revisions"][0]["approved_by"], "erin");
  EXPECT_FALSE(revs["revisions"][1].contains("approved_by"));
  EXPECT_EQ(revs["revisions"][1]["summary"]["tolerance_version"], 2);
  EXPECT_EQ(Call("POST", path + "/approve", engineer_, R"({"revision": 1})").status, 409);
  EXPECT_EQ(Call("POST", path + "/approve", engineer_).status, 200);
  Pdf(path + ".pdf?revision=2");
}

TEST_F(Certificates, AsFoundAndAsLeftAreTheUsersChoiceOfOneSetUp) {
  const auto found = Upload(Dbb("ccw"));
  const auto cw = Upload(Dbb("cw"));
  const auto before = Upload(Dbb("ccw", "2026-10-01T08:00:00Z"));
  const auto left = Upload(
      Replaced(Dbb("ccw", "2026-11-03T09:00:00Z"), "temperature_c: 20.4", "temperature_c: 20.6"));
  const std::string path = "/api/v1/measurements/" + std::to_string(found) + "/report.pdf";
  const std::string plain = Text(Pdf(path));
  EXPECT_EQ(plain.find("As found / as left"), std::string::npos);  // not chosen: not shown
  const std::string text = Text(Pdf(path + "?as_left=" + std::to_string(left)));
  EXPECT_NE(text.find("As found / as left"), std::string::npos) << text;
  EXPECT_NE(
      text.find("-L" + std::string(6 - std::to_string(left).size(), '0') + std::to_string(left)),
      std::string::npos);
  for (const auto& [other, why] : std::vector<std::pair<std::int64_t, std::string>>{
           {cw, "same set-up"}, {before, "after"}, {found, "itself"}, {9999, "does not exist"}}) {
    const auto r = Call("GET", path + "?as_left=" + std::to_string(other), viewer_);
    EXPECT_EQ(r.status, 400) << other;
    EXPECT_EQ(json::parse(r.body)["field"], "as_left");
    EXPECT_NE(r.body.find(why), std::string::npos) << r.body;
  }
  EXPECT_EQ(Call("GET", path + "?as_left=x", viewer_).status, 400);
}

TEST_F(Certificates, ALaserTestAsFoundAndAsLeftWithBothCompensationTables) {
  const std::string file = Example("positioning_x.txt");
  const auto found = Upload(file);
  // After the adjustment: the same axis a day later, every reading 3 µm nearer its target.
  std::string after = Replaced(file, "2026-11-20T09:30:00Z", "2026-11-21T09:30:00Z");
  after = Replaced(after, "1,+,50.3,50.31642", "1,+,50.3,50.31342");
  const auto left = Upload(after);
  const std::string text = Text(Pdf("/api/v1/measurements/" + std::to_string(found) +
                                    "/report.pdf?as_left=" + std::to_string(left)));
  EXPECT_NE(text.find("Compensation tables, as found and as left"), std::string::npos) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex("As found fwd.*As left rev")));
  EXPECT_TRUE(std::regex_search(text, std::regex("accuracy of positioning A.*µm")));
  ExpectNoRawKeys(text);
}

TEST_F(Certificates, JobAndAuditReportsAreCertificatesToo) {
  const json audit{
      {"rules", {{{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 5}, {"stop", 50}}}}};
  ASSERT_EQ(Call("PUT", "/api/v1/machines/vmc-3axis/audit", engineer_, audit.dump()).status, 200);
  Upload(Dbb("ccw"));
  ASSERT_EQ(Call("POST", "/api/v1/machines/vmc-3axis/audit/run", engineer_).status, 201);
  const std::string path = "/api/v1/machines/vmc-3axis/audit/report";
  const std::string text = Text(Pdf(path + ".pdf"));
  EXPECT_NE(text.find("KM-A-vmc-3axis, revision 1"), std::string::npos) << text;
  ASSERT_EQ(Call("POST", path + "/approve", engineer_).status, 200);
  EXPECT_NE(Text(Pdf(path + ".pdf")).find("approved by erin"), std::string::npos);
  // Another audit run is a new revision.
  ASSERT_EQ(Call("POST", "/api/v1/machines/vmc-3axis/audit/run", engineer_).status, 201);
  EXPECT_NE(Text(Pdf(path + ".pdf")).find("KM-A-vmc-3axis, revision 2"), std::string::npos);
  EXPECT_EQ(Call("POST", "/api/v1/jobs/77/report/approve", engineer_).status, 404);
  EXPECT_EQ(Call("GET", "/api/v1/machines/nowhere/audit/report/revisions", viewer_).status, 404);
}

}  // namespace
}  // namespace km::api
