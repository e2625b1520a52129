// Field checks of JSON API requests (server/base/request_json.h).
#include "server/base/request_json.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

namespace km::server::request {
namespace {

using nlohmann::json;

constexpr std::int64_t kMin = std::numeric_limits<std::int64_t>::min();
constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();

TEST(RequestJson, WholeNumberTakesTheWholeInt64Range) {
  EXPECT_EQ(WholeNumber(json::parse(R"({"t": -9223372036854775808})"), "t", kMin, kMax), kMin);
  EXPECT_EQ(WholeNumber(json::parse(R"({"t": 9223372036854775807})"), "t", kMin, kMax), kMax);
  EXPECT_EQ(WholeNumber(json::parse(R"({"t": 7})"), "t", 0, 10), 7);
  EXPECT_EQ(WholeNumber(json::object(), "t", 0, 10, 3), 3);
}

TEST(RequestJson, WholeNumberRefusesNumbersBeyondInt64) {
  // Above the int64 range the JSON reader keeps the number unsigned; it must not wrap around
  // into a negative number that a wide range accepts (2^64 - 1 would read as -1).
  for (const char* text : {R"({"t": 18446744073709551615})", R"({"t": 9223372036854775808})"}) {
    try {
      const auto v = WholeNumber(json::parse(text), "t", kMin, kMax);
      ADD_FAILURE() << text << " accepted as " << v;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "request");
      EXPECT_EQ(e.field(), "t");
    }
  }
}

TEST(RequestJson, WholeNumberRefusesOtherTypesAndOutOfRange) {
  for (const char* text : {R"({"t": 1.5})", R"({"t": "1"})", R"({"t": 11})", R"({"t": -1})"}) {
    EXPECT_THROW(WholeNumber(json::parse(text), "t", 0, 10), InvalidInput) << text;
  }
  EXPECT_THROW(WholeNumber(json::object(), "t", 0, 10), InvalidInput);
}

}  // namespace
}  // namespace km::server::request
