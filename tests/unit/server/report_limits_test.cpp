// The bounds of the service's PDF reports: the report of a laser file of 100 000 targets is a
// few pages that say how its targets table was summarised and where the full table is; an audit
// of 200 rules with 200 findings is summarised the same way; the render gate makes at most its
// limit of reports at a time, refuses more at once (km::Unavailable: 503 with Retry-After), and
// a stop refuses waiting reports and cancels a long running one within its deadline.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>
#include <thread>

#include <unistd.h>

#include "analysis/core/errors.h"
#include "render/pdf_report.h"
#include "server/reports/render_gate.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "usecases/pdf_reports.h"

namespace km::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string Output(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  std::array<char, 4096> buf;
  std::size_t n;
  while (p && (n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  if (p) pclose(p);
  return out;
}

// A laser positioning file (docs/formats.md §1.8) of `targets` targets, 2 runs, both directions.
std::string PositioningFile(int targets) {
  std::ostringstream f;
  f << "# format: kinemetric-positioning/1\n# machine_id: long-axis\n# axis: X\n"
    << "# timestamp: 2026-11-20T09:30:00Z\n# cycle: linear\n# datum_mm: 0\n"
    << "# air_compensated: yes\nrun,direction,target_mm,deviation_um\n";
  char line[96];
  for (int run = 1; run <= 2; ++run) {
    for (int i = 0; i < targets; ++i) {
      std::snprintf(line, sizeof line, "%d,+,%d.0,%.3f\n", run, i, 0.5 * (i % 13) + 0.1 * run);
      f << line;
    }
    for (int i = targets - 1; i >= 0; --i) {
      std::snprintf(line, sizeof line, "%d,-,%d.0,%.3f\n", run, i, 0.5 * (i % 13) - 0.1 * run);
      f << line;
    }
  }
  return f.str();
}

class ReportLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("km-report-limits-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::unique_ptr<Service> NewService() {
    auto svc = std::make_unique<Service>(std::make_unique<SqliteStorage>((dir_ / "db").string()),
                                         ServiceOptions{});
    RegisterBuiltinKinds(svc->measurements());
    return svc;
  }
  // (pages, text on one line) of a PDF.
  std::pair<int, std::string> Read(const std::string& pdf) {
    const auto path = (dir_ / "r.pdf").string();
    std::ofstream(path, std::ios::binary) << pdf;
    const std::string info = Output("pdfinfo '" + path + "' 2>&1");
    const auto at = info.find("Pages:");
    std::string text = Output("pdftotext '" + path + "' - 2>&1");
    for (auto& c : text) c = c == '\n' ? ' ' : c;
    return {at == std::string::npos ? -1 : std::stoi(info.substr(at + 6)), text};
  }
  fs::path dir_;
};

TEST_F(ReportLimitsTest, TheReportOfAHundredThousandTargetsIsAFewPagesAndSaysSo) {
  auto svc = NewService();
  const auto id = svc->measurements().Upload(PositioningFile(100'000), "long.txt").id;
  const auto t0 = Clock::now();
  const std::string pdf = svc->reports().MeasurementPdf(id);
  const double s = Since(t0);
  const auto [pages, text] = Read(pdf);
  std::printf("100 000 targets: %d pages, %zu bytes, %.2f s\n", pages, pdf.size(), s);
  EXPECT_GE(pages, 2);
  EXPECT_LE(pages, render::kMaxReportPages);
  const std::string id_s = to_string(id);
  for (const std::string& want :
       {std::string("200 of 100000 targets shown"), std::string("evenly spaced"),
        "GET /api/v1/measurements/" + id_s + "/results",
        "GET /api/v1/measurements/" + id_s + "/compensation?format=csv", std::string("99999"),
        std::string("Approved by")}) {
    EXPECT_NE(text.find(want), std::string::npos) << "missing '" << want << "'";
  }
  EXPECT_EQ(text.find("page limit"), std::string::npos) << "summarised, not cut";
}

TEST_F(ReportLimitsTest, AnAuditOfTwoHundredRulesAndFindingsIsSummarised) {
  nlohmann::json rules = nlohmann::json::array(), checked = nlohmann::json::array(),
                 findings = nlohmann::json::array();
  for (int i = 0; i < 200; ++i) {
    rules.push_back({{"kind", "dbb"}, {"metric", "circularity_um"}, {"warn", 1}, {"stop", 2}});
    checked.push_back(
        {{"rule", i}, {"status", "finding"}, {"level", i % 5 == 0 ? 3 : 2}, {"value", 1.5}});
    findings.push_back({{"level", i % 5 == 0 ? 3 : 2},
                        {"message", "rule " + std::to_string(i) +
                                        ": circularity above warn, "
                                        "a sentence long enough to "
                                        "wrap onto a second line of "
                                        "its cell in the table"},
                        {"measurement_id", i + 1}});
  }
  const nlohmann::json config = {{"rules", rules}, {"schedule", nullptr}};
  const nlohmann::json verdict = {{"id", 9},
                                  {"level", 3},
                                  {"checked", checked},
                                  {"findings", findings},
                                  {"trigger", "manual"},
                                  {"created_at", "2026-04-02T00:00:00Z"}};
  const auto [pages, text] = Read(render::RenderPdf(usecases::AuditPdfReport(
      "vmc-9", config, nlohmann::json::array({verdict}), "2026-04-02T00:00:00Z")));
  EXPECT_LE(pages, render::kMaxReportPages);
  // 40 findings of level 3: every one of them shown.
  EXPECT_NE(text.find("of 200 findings shown (evenly spaced from the first to the last, and every "
                      "one of the findings of the highest level)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("of 200 rules shown"), std::string::npos);
  EXPECT_NE(text.find("GET /api/v1/machines/vmc-9/audit"), std::string::npos);
}

// A job that waits until `release` is set (or it is cancelled), then returns "done".
RenderGate::Job Held(std::shared_future<void> release) {
  return [release](const std::function<bool()>& cancelled) {
    while (release.wait_for(std::chrono::milliseconds(5)) != std::future_status::ready) {
      if (cancelled()) throw render::RenderCancelled("cancelled");
    }
    return std::string("done");
  };
}

bool WaitFor(const std::function<bool()>& ok) {
  const auto t0 = Clock::now();
  while (!ok()) {
    if (Since(t0) > 5) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

TEST_F(ReportLimitsTest, TheGateRefusesReportsBeyondItsLimitAtOnce) {
  RenderGate gate({1, 1, std::chrono::milliseconds(10'000)});
  std::promise<void> go;
  const std::shared_future<void> release = go.get_future().share();
  auto first = std::async(std::launch::async, [&] { return gate.Run(Held(release)); });
  ASSERT_TRUE(WaitFor([&] { return gate.running() == 1; }));
  auto second = std::async(std::launch::async, [&] { return gate.Run(Held(release)); });
  ASSERT_TRUE(WaitFor([&] { return gate.waiting() == 1; }));
  const auto t0 = Clock::now();
  try {
    gate.Run(Held(release));
    ADD_FAILURE() << "a third report was taken";
  } catch (const Unavailable& e) {
    EXPECT_NE(std::string(e.what()).find("retry"), std::string::npos) << e.what();
  }
  EXPECT_LT(Since(t0), 0.1) << "refused at once";
  go.set_value();
  EXPECT_EQ(first.get(), "done");
  EXPECT_EQ(second.get(), "done");
  EXPECT_EQ(gate.Run(Held(release)), "done") << "room again";
}

TEST_F(ReportLimitsTest, AStopCancelsALongRenderAndRefusesTheWaitingOnes) {
  RenderGate gate({1, 2, std::chrono::milliseconds(10'000)});
  // A long render: 200 000 rows without a page budget take seconds.
  render::Report big;
  big.title = "long";
  render::ReportTable t;
  t.header = {"row"};
  for (int i = 0; i < 200'000; ++i) t.rows.push_back({std::to_string(i)});
  big.blocks.push_back(render::TableBlock(std::move(t)));
  auto running = std::async(std::launch::async, [&] {
    return gate.Run([&](const std::function<bool()>& cancelled) {
      render::RenderOptions o;
      o.max_pages = 1'000'000;
      o.cancelled = cancelled;
      return render::RenderPdf(big, o);
    });
  });
  ASSERT_TRUE(WaitFor([&] { return gate.running() == 1; }));
  std::promise<void> never;
  const std::shared_future<void> held = never.get_future().share();
  auto waiting = std::async(std::launch::async, [&] { return gate.Run(Held(held)); });
  ASSERT_TRUE(WaitFor([&] { return gate.waiting() == 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto t0 = Clock::now();
  gate.Stop(Clock::now() + std::chrono::milliseconds(200));
  EXPECT_THROW(waiting.get(), Unavailable);
  EXPECT_LT(Since(t0), 0.1) << "a waiting report is refused at once";
  EXPECT_THROW(running.get(), Unavailable);
  const double s = Since(t0);
  std::printf("long render cancelled %.3f s after the stop (deadline 0.2 s)\n", s);
  EXPECT_GE(s, 0.15);
  EXPECT_LT(s, 1.0);
  EXPECT_THROW(gate.Run(Held(held)), Unavailable) << "stopped";
}

TEST_F(ReportLimitsTest, AStoppedServiceRefusesReports) {
  auto svc = NewService();
  std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/data/examples/positioning_x.txt");
  std::stringstream ss;
  ss << in.rdbuf();
  const auto id = svc->measurements().Upload(ss.str(), "positioning_x.txt").id;
  EXPECT_EQ(svc->reports().MeasurementPdf(id).rfind("%PDF-", 0), 0u);
  EXPECT_THROW(svc->reports().MeasurementPdf(MeasurementId(999)), NotFound);
  svc->reports().Stop(Clock::now());
  EXPECT_THROW(svc->reports().MeasurementPdf(id), Unavailable);
}

}  // namespace
}  // namespace km::server
