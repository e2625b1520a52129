// The list of accuracy-audit verdicts (GET /api/v1/audits) over a real service and SQLite file:
// a machine with 200 rules run many times gives verdicts of about 80 kB each; a page asked for
// 1000 of them stops below its byte budget, says so (truncated, next_offset), and paging
// through lists every verdict exactly once, newest first, each as GET /api/v1/audits/{id}
// answers it. The edges of a page: the count limit reached with more or none after it, one
// verdict larger than the budget, an offset past the end.
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>

#include "server/audits/audit_service.h"
#include "server/demo/demo_data.h"
#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server::test {
namespace {

using nlohmann::json;

constexpr std::int64_t kNow = 1795749120;  // 2026-11-27T03:12:00Z

class AuditListing : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    svc_ =
        std::make_unique<Service>(std::make_unique<SqliteStorage>(Path("k.db")), ServiceOptions{});
    RegisterBuiltinKinds(svc_->measurements());
  }
  // 200 rules over the DBB test of demo-vmc, each a finding; `runs` verdicts a minute apart.
  void RunLargeAudits(int runs) {
    const auto demo = DemoDbbFiles().at(0);
    svc_->measurements().Upload(demo.bytes, demo.name);
    const char* metrics[] = {"circularity_um", "min_zone_circularity_um", "centre_offset_um",
                             "circular_deviation_um", "average_radial_error_um"};
    json rules = json::array();
    for (int i = 0; i < 200; ++i) {
      rules.push_back({{"kind", "dbb"}, {"metric", metrics[i % 5]}, {"warn", 0.0}});
    }
    PutAuditConfig(*svc_, "demo-vmc", {{"rules", rules}}, kNow);
    for (int i = 0; i < runs; ++i) RunAccuracyAudit(*svc_, "demo-vmc", "manual", kNow + 60 * i);
  }
  // A verdict stored as it is, with `bytes` of padding in its findings; its id.
  AuditVerdictId AddVerdict(std::size_t bytes, int minute) {
    AuditVerdictRecord v;
    v.machine_id = "vmc";
    v.trigger = "manual";
    v.created_at = IsoFromUnixSeconds(kNow + 60 * minute);
    v.verdict_json = json{
        {"findings", json::array({std::string(bytes, 'x')})},
        {"checked",
         json::array()}}.dump();
    return svc_->storage().AddAuditVerdict(v);
  }
  json Page(std::int64_t limit, std::int64_t offset, std::size_t max_bytes = kAuditPageBytes) {
    AuditVerdictFilter f;
    f.limit = limit;
    f.offset = offset;
    const std::string text = ListAccuracyAuditsText(*svc_, f, max_bytes);
    last_bytes_ = text.size();
    return json::parse(text);
  }
  std::unique_ptr<Service> svc_;
  std::size_t last_bytes_ = 0;
};

TEST_F(AuditListing, ManyLargeVerdictsArePagedByBytesAndEachListedOnce) {
  constexpr int kRuns = 120;
  RunLargeAudits(kRuns);
  const std::string one = AccuracyAuditJson(*svc_, AuditVerdictId(1)).dump();
  ASSERT_GT(one.size(), 60000u) << "200 findings and 200 checked rules";
  ASSERT_GT(one.size() * kRuns, 2 * kAuditPageBytes);

  const json first = Page(1000, 0);
  EXPECT_LE(last_bytes_, kAuditPageBytes);
  EXPECT_GT(last_bytes_, kAuditPageBytes - 2 * one.size()) << "the page is filled";
  EXPECT_EQ(first.at("truncated"), true);
  EXPECT_EQ(first.at("limit"), 1000);
  EXPECT_EQ(first.at("offset"), 0);
  EXPECT_EQ(first.at("next_offset"), first.at("audits").size());
  EXPECT_EQ(first.at("audits")[0], AccuracyAuditJson(*svc_, AuditVerdictId(kRuns)))
      << "newest first, whole";

  std::set<std::int64_t> seen;
  std::int64_t offset = 0, previous = kRuns + 1;
  int pages = 0;
  for (json page = first; ++pages < 100; page = Page(1000, offset)) {
    EXPECT_LE(last_bytes_, kAuditPageBytes);
    EXPECT_FALSE(page.at("audits").empty());
    for (const auto& v : page.at("audits")) {
      const auto id = v["id"].get<std::int64_t>();
      EXPECT_TRUE(seen.insert(id).second) << "verdict " << id << " listed twice";
      EXPECT_LT(id, previous) << "newest first";
      previous = id;
    }
    if (page.at("next_offset").is_null()) {
      EXPECT_EQ(page.at("truncated"), false);
      break;
    }
    offset = page.at("next_offset").get<std::int64_t>();
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(kRuns));
  EXPECT_GE(pages, 3);
  // The service's own readers (the audit report's history) are bounded by the count only.
  AuditVerdictFilter f;
  f.limit = 1000;
  const json all = ListAccuracyAudits(*svc_, f);
  EXPECT_EQ(all.at("audits").size(), static_cast<std::size_t>(kRuns));
  EXPECT_EQ(all.at("audits")[0], first.at("audits")[0]);
  EXPECT_TRUE(all.at("next_offset").is_null());
}

TEST_F(AuditListing, TheCountLimitAndTheEndOfTheListAreTold) {
  for (int i = 0; i < 5; ++i) AddVerdict(100, i);
  json page = Page(2, 0);
  EXPECT_EQ(page.at("audits").size(), 2u);
  EXPECT_EQ(page.at("audits")[0]["id"], 5);
  EXPECT_EQ(page.at("truncated"), false);  // the limit, not the budget, ended it
  EXPECT_EQ(page.at("next_offset"), 2);
  page = Page(2, 4);
  EXPECT_EQ(page.at("audits").size(), 1u);
  EXPECT_EQ(page.at("audits")[0]["id"], 1);
  EXPECT_TRUE(page.at("next_offset").is_null());
  page = Page(5, 0);  // exactly all: no next page
  EXPECT_EQ(page.at("audits").size(), 5u);
  EXPECT_TRUE(page.at("next_offset").is_null());
  page = Page(10, 9);
  EXPECT_TRUE(page.at("audits").empty());
  EXPECT_TRUE(page.at("next_offset").is_null());
  EXPECT_EQ(page.at("offset"), 9);
}

TEST_F(AuditListing, APageHoldsOneVerdictLargerThanTheBudgetAndStopsBeforeTheBudget) {
  AddVerdict(3000, 0);  // id 1, the oldest
  AddVerdict(400, 1);
  AddVerdict(400, 2);
  AddVerdict(5000, 3);  // id 4, the newest: alone larger than the budget
  json page = Page(100, 0, 2000);
  ASSERT_EQ(page.at("audits").size(), 1u);
  EXPECT_EQ(page.at("audits")[0]["id"], 4);
  EXPECT_EQ(page.at("truncated"), true);
  EXPECT_EQ(page.at("next_offset"), 1);
  page = Page(100, 1, 2000);
  EXPECT_LE(last_bytes_, 2000u);
  ASSERT_EQ(page.at("audits").size(), 2u);
  EXPECT_EQ(page.at("next_offset"), 3);
  EXPECT_EQ(page.at("truncated"), true);
  page = Page(100, 3, 2000);  // the last verdict, alone over the budget: nothing after it
  ASSERT_EQ(page.at("audits").size(), 1u);
  EXPECT_EQ(page.at("audits")[0]["id"], 1);
  EXPECT_EQ(page.at("truncated"), false);
  EXPECT_TRUE(page.at("next_offset").is_null());
}

}  // namespace
}  // namespace km::server::test
