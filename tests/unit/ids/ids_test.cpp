// The typed ids of the stored tables (server/base/ids.h).
#include "server/base/ids.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <type_traits>
#include <unordered_set>

namespace km::server {
namespace {

using nlohmann::json;

// An id of one table is never taken for another's, nor made from an integer without saying so.
static_assert(!std::is_convertible_v<MeasurementId, JobId>);
static_assert(!std::is_constructible_v<JobId, MeasurementId>);
static_assert(!std::is_constructible_v<TokenId, StreamId>);
static_assert(!std::is_convertible_v<std::int64_t, MeasurementId>);
static_assert(!std::is_convertible_v<MeasurementId, std::int64_t>);
static_assert(!std::is_convertible_v<int, AuditVerdictId>);
static_assert(std::is_constructible_v<MeasurementId, std::int64_t>);
static_assert(std::is_trivially_copyable_v<JobId>);
static_assert(sizeof(StreamId) == sizeof(std::int64_t));

TEST(Ids, KeepTheirIntegerAndCompareByIt) {
  const MeasurementId a(7), b(9);
  EXPECT_EQ(a.value(), 7);
  EXPECT_EQ(a, MeasurementId(7));
  EXPECT_NE(a, b);
  EXPECT_LT(a, b);
  EXPECT_EQ(MeasurementId().value(), 0);
}

TEST(Ids, AreWrittenToJsonAsThePlainInteger) {
  const json j = {{"id", JobId(42)}, {"measurement_id", MeasurementId(9223372036854775807)}};
  EXPECT_EQ(j.dump(), R"({"id":42,"measurement_id":9223372036854775807})");
  EXPECT_EQ(j.at("id").get<JobId>(), JobId(42));
  EXPECT_EQ(json::parse(j.dump()).at("measurement_id").get<MeasurementId>().value(),
            std::numeric_limits<std::int64_t>::max());
  EXPECT_THROW(json("7").get<TokenId>(), json::type_error);
}

TEST(Ids, HashLikeTheirInteger) {
  EXPECT_EQ(std::hash<StreamId>{}(StreamId(5)), std::hash<std::int64_t>{}(5));
  std::unordered_set<TokenId> seen{TokenId(1), TokenId(2), TokenId(1)};
  EXPECT_EQ(seen.size(), 2u);
  EXPECT_TRUE(seen.contains(TokenId(2)));
  EXPECT_FALSE(seen.contains(TokenId(3)));
}

TEST(Ids, PrintAsTheirInteger) {
  std::ostringstream os;
  os << "job " << JobId(12);
  EXPECT_EQ(os.str(), "job 12");
  EXPECT_EQ(to_string(AuditVerdictId(3)), "3");
}

TEST(Ids, NoneIsZeroOnlyWhereTheFormatSaysSo) {
  EXPECT_EQ(ValueOrZero(std::optional<TokenId>()), 0);
  EXPECT_EQ(ValueOrZero(std::optional<TokenId>(TokenId(4))), 4);
  EXPECT_EQ(IdOrNone<JobId>(0), std::nullopt);
  EXPECT_EQ(IdOrNone<JobId>(8), JobId(8));
}

}  // namespace
}  // namespace km::server
