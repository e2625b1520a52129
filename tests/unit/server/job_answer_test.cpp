// The server's answer of a job (GET /api/v1/jobs/{id}, the list, the jobs of a machine) names the
// machine it is of as machine_id, also for a serial discovery whose request names no model, and
// the job's PDF report names it from there.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "render/pdf_report.h"
#include "server/jobs/study_requests.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/pdf_text.h"
#include "tests/unit/server/temp_dir.h"
#include "usecases/pdf_reports.h"

namespace km::server {
namespace {

using nlohmann::json;

class JobAnswer : public test::TempDirTest {};

// The server's job answer names the machine of a serial discovery's DBB tests.
TEST_F(JobAnswer, TheJobAnswerNamesTheMachineOfASerialDiscovery) {
  ServiceOptions options;
  options.jobs.workers = 0;  // the job stays queued
  Service service(std::make_unique<SqliteStorage>(Path("km.db")), options);
  RegisterBuiltinKinds(service.measurements());
  const auto read = [](const std::string& name) {
    std::ifstream in(std::string(KINEMETRIC_SOURCE_DIR) + "/tests/fixtures/browser/" + name);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  const auto ccw = service.measurements().Upload(read("dbb_xy-r150_ccw.txt"), "ccw.txt").id;
  const auto cw = service.measurements().Upload(read("dbb_xy-r150_cw.txt"), "cw.txt").id;
  const auto id =
      service.studies().SubmitDiscovery(DiscoveryRequest::Parse({{"measurement_ids", {ccw, cw}}}));
  const json job = service.studies().Job(id);
  EXPECT_FALSE(job["request"].contains("machine_id")) << job.dump();
  EXPECT_EQ(job.value("machine_id", json()), "browser-test-vmc") << job.dump();
  const json list = service.studies().Jobs(10);
  ASSERT_EQ(list["items"].size(), 1u);
  EXPECT_EQ(list["items"][0].value("machine_id", json()), "browser-test-vmc");
  EXPECT_EQ(service.studies().JobsOfMachine("browser-test-vmc", 10)["items"].size(), 1u);
  const std::string text = km::test::PdfToText(
      render::RenderPdf(usecases::JobPdfReport(job, "2025-03-05")), Path("job.pdf"));
  EXPECT_TRUE(std::regex_search(text, std::regex(R"(Machine\s+browser-test-vmc)"))) << text;
  EXPECT_NE(text.find("Discovery — queued"), std::string::npos) << text;
}

}  // namespace
}  // namespace km::server
