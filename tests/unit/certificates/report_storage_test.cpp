// Report revisions and approvals on both storage backends, SQLite and PostgreSQL
// (tests/unit/server/storage_backends.h), with the same answers: revisions appended per subject
// when the content's SHA-256 changes, the newest given back when it does not, one approval per
// revision with its PDF bytes exact (binary, a NUL inside), two instances numbering in turn.
#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

#include "server/storage/storage.h"
#include "tests/unit/server/storage_backends.h"

namespace km::server {
namespace {

using test::Backends;

NewReportRevision Rev(const std::string& subject, const std::string& content) {
  return {subject, "sha-" + content, R"({"of":")" + content + "\"}"};
}

TEST_P(Backends, ReportRevisionsAreAppendedWhenWhatTheyCertifyChanges) {
  auto s = Open();
  EXPECT_TRUE(s->ListReportRevisions("measurement 1").empty());
  const auto r1 = s->PutReportRevision(Rev("measurement 1", "a"));
  EXPECT_TRUE(r1.created);
  EXPECT_EQ(r1.record.revision, 1);
  EXPECT_EQ(r1.record.created_at.size(), 20u);
  const auto same = s->PutReportRevision(Rev("measurement 1", "a"));
  EXPECT_FALSE(same.created);
  EXPECT_EQ(same.record.revision, 1);
  EXPECT_EQ(s->PutReportRevision(Rev("measurement 1", "b")).record.revision, 2);
  EXPECT_EQ(s->PutReportRevision(Rev("job 1", "b")).record.revision, 1);
  // Back to the first content: a new revision, never the old one reopened.
  EXPECT_EQ(s->PutReportRevision(Rev("measurement 1", "a")).record.revision, 3);
  const auto list = s->ListReportRevisions("measurement 1");
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0].revision, 1);
  EXPECT_EQ(list[1].content_sha256, "sha-b");
  EXPECT_EQ(list[1].summary_json, R"({"of":"b"})");
  EXPECT_FALSE(list[2].approval);
}

TEST_P(Backends, AnApprovalIsStoredOnceWithItsPdfByteForByte) {
  auto s = Open();
  s->PutReportRevision(Rev("audit vmc", "a"));
  const char raw[] = "%PDF-1.5\n\0\xff\xfe binary %%EOF";
  const std::string pdf(raw, sizeof(raw) - 1);
  ASSERT_TRUE(
      s->AddReportApproval({"audit vmc", 1, "ann", TokenId(7), "2026-12-01T10:00:00Z", pdf}));
  EXPECT_FALSE(
      s->AddReportApproval({"audit vmc", 1, "bob", TokenId(8), "2026-12-01T11:00:00Z", "x"}));
  EXPECT_EQ(s->ReportApprovalPdf("audit vmc", 1), pdf);
  EXPECT_FALSE(s->ReportApprovalPdf("audit vmc", 2));
  EXPECT_FALSE(s->ReportApprovalPdf("audit other", 1));
  auto again = Open();  // another instance on the same database
  const auto list = again->ListReportRevisions("audit vmc");
  ASSERT_EQ(list.size(), 1u);
  ASSERT_TRUE(list[0].approval);
  EXPECT_EQ(list[0].approval->approved_by, "ann");
  EXPECT_EQ(list[0].approval->token_id, TokenId(7));
  EXPECT_EQ(list[0].approval->approved_at, "2026-12-01T10:00:00Z");
  EXPECT_TRUE(list[0].approval->pdf.empty());  // listed without its document
  // The newest revision comes back with its approval.
  const auto put = again->PutReportRevision(Rev("audit vmc", "a"));
  ASSERT_TRUE(put.record.approval);
  EXPECT_EQ(put.record.approval->approved_by, "ann");
}

TEST_P(Backends, ReportRevisionsOfTwoWritersAreNumberedInTurn) {
  auto a = Open();
  auto b = Open();
  std::vector<std::thread> threads;
  for (int w = 0; w < 2; ++w) {
    threads.emplace_back([&, w] {
      Storage& s = w == 0 ? *a : *b;
      for (int i = 0; i < 10; ++i) {
        s.PutReportRevision(Rev("measurement 9", std::to_string(w * 100 + i)));
      }
    });
  }
  for (auto& t : threads) t.join();
  const auto list = a->ListReportRevisions("measurement 9");
  ASSERT_EQ(list.size(), 20u);
  for (std::size_t i = 0; i < list.size(); ++i) EXPECT_EQ(list[i].revision, i + 1);
}

}  // namespace
}  // namespace km::server
