// Strict UTF-8 checks and U+FFFD replacement (server/base/utf8.h), and stored text that is not
// UTF-8 (rows written before uploads were checked) listed without failing.
#include "server/base/utf8.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <nlohmann/json.hpp>

#include "server/service.h"
#include "server/storage/sqlite/sqlite_storage.h"
#include "tests/unit/server/temp_dir.h"

namespace km::server {
namespace {

const std::string kFffd = "\xEF\xBF\xBD";

TEST(Utf8, AcceptsValidTextOfEveryLength) {
  for (const std::string& s :
       {std::string(""), std::string("plain ascii"), std::string("\0nul", 4),
        std::string("\xC2\x80"), std::string("\xDF\xBF"), std::string("µm ± 0.5 °C"),
        std::string("\xE0\xA0\x80"), std::string("\xED\x9F\xBF"), std::string("\xEE\x80\x80"),
        std::string("\xEF\xBF\xBF"), std::string("\xF0\x90\x80\x80"),
        std::string("\xF4\x8F\xBF\xBF"), std::string("日本語のファイル.txt")}) {
    EXPECT_TRUE(IsValidUtf8(s)) << s;
    EXPECT_EQ(SanitizeUtf8(s), s);
  }
}

TEST(Utf8, RefusesEveryKindOfBadSequence) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"\x80", kFffd},                                      // lone continuation byte
      {"\xBF", kFffd},                                      //
      {"\xC0\xAF", kFffd + kFffd},                          // overlong '/'
      {"\xC1\xBF", kFffd + kFffd},                          // overlong
      {"\xE0\x80\xAF", kFffd + kFffd + kFffd},              // overlong 3-byte
      {"\xE0\x9F\xBF", kFffd + kFffd + kFffd},              // overlong 3-byte (U+07FF)
      {"\xF0\x8F\xBF\xBF", kFffd + kFffd + kFffd + kFffd},  // overlong 4-byte
      {"\xED\xA0\x80", kFffd + kFffd + kFffd},              // surrogate U+D800
      {"\xED\xBF\xBF", kFffd + kFffd + kFffd},              // surrogate U+DFFF
      {"\xF4\x90\x80\x80", kFffd + kFffd + kFffd + kFffd},  // U+110000
      {"\xF5\x80\x80\x80", kFffd + kFffd + kFffd + kFffd},  // beyond any plane
      {"\xFF", kFffd},
      {"\xFE", kFffd},
      {"\xC3", kFffd},          // truncated at the end
      {"\xE2\x82", kFffd},      // truncated: one replacement
      {"\xF0\x9F\x98", kFffd},  //
      {"a\xE2\x82"
       "b",
       "a" + kFffd + "b"},     // truncated in the middle
      {"\xC3(", kFffd + "("},  // bad continuation
      {"ok \xFF\xFE ok", "ok " + kFffd + kFffd + " ok"},
      {"caf\xE9.txt", "caf" + kFffd + ".txt"},  // Latin-1 file name
  };
  for (const auto& [in, out] : cases) {
    EXPECT_FALSE(IsValidUtf8(in)) << ::testing::PrintToString(in);
    EXPECT_EQ(SanitizeUtf8(in), out) << ::testing::PrintToString(in);
    EXPECT_TRUE(IsValidUtf8(SanitizeUtf8(in)));
    EXPECT_NO_THROW((void)nlohmann::json(SanitizeUtf8(in)).dump());
  }
}

TEST(Utf8, EveryTwoByteStringIsSanitisedToValidText) {
  for (int a = 0; a < 256; ++a) {
    for (int b = 0; b < 256; ++b) {
      const std::string s{static_cast<char>(a), static_cast<char>(b)};
      const std::string t = SanitizeUtf8(s);
      ASSERT_TRUE(IsValidUtf8(t)) << a << " " << b;
      ASSERT_NO_THROW((void)nlohmann::json(t).dump());
      if (IsValidUtf8(s)) {
        ASSERT_EQ(t, s);
      }
    }
  }
}

class StoredNonUtf8 : public test::TempDirTest {};

// A row stored before file names were checked, with Latin-1 bytes in its file name and machine,
// is listed (with U+FFFD in their place) instead of failing every listing.
TEST_F(StoredNonUtf8, ListingARowWithABadFileNameWorks) {
  const std::string db = Path("kinemetric.db");
  { SqliteStorage create(db); }
  {
    sqlite3* raw = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
    const char* sql =
        "INSERT INTO measurements (sha256, kind, format, machine_id, test_id, direction, "
        "measured_at, uploaded_at, filename, sample_count, metadata_json, raw, samples) VALUES "
        "('ab12', 'dbb', 'kinemetric-dbb/1', CAST(X'766d63E9' AS TEXT), 't', 'ccw', NULL, "
        "'2020-01-01T00:00:00Z', CAST(X'6361667EE92E747874FF' AS TEXT), 0, "
        "CAST(X'7B226F776E6572223A22E9227D' AS TEXT), X'00', X'')";
    char* err = nullptr;
    ASSERT_EQ(sqlite3_exec(raw, sql, nullptr, nullptr, &err), SQLITE_OK) << (err ? err : "");
    sqlite3_close(raw);
  }
  Service svc(std::make_unique<SqliteStorage>(db), {});
  const auto page = svc.storage().ListMeasurements({});
  ASSERT_EQ(page.items.size(), 1u);
  const auto& rec = page.items[0];
  EXPECT_EQ(rec.filename, "caf~" + kFffd + ".txt" + kFffd);
  EXPECT_EQ(rec.machine_id, "vmc" + kFffd);
  std::string listed;
  ASSERT_NO_THROW(listed = svc.measurements().MeasurementJson(rec).dump());
  EXPECT_NE(listed.find("caf~" + kFffd + ".txt"), std::string::npos) << listed;
  const auto one = svc.storage().GetMeasurement(rec.id);
  ASSERT_TRUE(one);
  EXPECT_NO_THROW((void)svc.measurements().MeasurementJson(*one).dump());
  EXPECT_NO_THROW((void)nlohmann::json::parse(one->metadata_json).dump());
  const auto machines = svc.storage().ListMachines();
  ASSERT_EQ(machines.size(), 1u);
  EXPECT_NO_THROW((void)nlohmann::json(machines[0].machine_id).dump());
}

}  // namespace
}  // namespace km::server
