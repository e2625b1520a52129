// ingest/json_text.h: every document the product reads as JSON. Documents within the limits
// come out exactly as nlohmann's own parser reads them (an independent reading); nesting past
// the limit, repeated keys and numbers beyond a double are refused naming file, line and field,
// also when the input is hundreds of thousands of levels deep (no recursion while reading).
#include "ingest/json_text.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

using nlohmann::json;

InvalidInput Refusal(const std::string& text, JsonTextLimits limits = {}) {
  try {
    ParseJsonText(text, "body.json", limits);
  } catch (const InvalidInput& e) {
    return e;
  }
  ADD_FAILURE() << "accepted: " << text.substr(0, 200);
  return InvalidInput("none");
}

std::string Nested(char open, char close, std::size_t depth, const std::string& inner = "") {
  return std::string(depth, open) + inner + std::string(depth, close);
}

TEST(JsonText, ReadsDocumentsAsNlohmannDoes) {
  const std::vector<std::string> docs = {
      R"({"a":1,"b":[1,2.5,-3e-7,"x",null,true,false],"c":{"d":{}},"e":[]})",
      R"([])",
      R"("text with \u00e9 and \n")",
      R"(18446744073709551615)",
      R"(-9223372036854775808)",
      R"(1.7976931348623157e308)",
      R"({"": 1, "k": [[[[1]]]]})",
      "\n  {\"multi\":\n [1,\n 2]}\n",
  };
  for (const auto& d : docs) {
    const json mine = ParseJsonText(d, "doc");
    EXPECT_EQ(mine, json::parse(d)) << d;
    EXPECT_EQ(mine.dump(), json::parse(d).dump()) << d;  // same types (integer, unsigned, float)
  }
}

TEST(JsonText, NestingUpToTheLimitIsRead) {
  const std::string at_limit = Nested('[', ']', kMaxJsonDepth, "7");
  EXPECT_EQ(ParseJsonText(at_limit, "doc"), json::parse(at_limit));
  std::string objects;
  for (std::size_t i = 0; i < kMaxJsonDepth; ++i) objects += "{\"k\":";
  objects += "1" + std::string(kMaxJsonDepth, '}');
  EXPECT_EQ(ParseJsonText(objects, "doc"), json::parse(objects));
}

TEST(JsonText, NestingPastTheLimitIsRefusedWithItsPath) {
  const auto e = Refusal(Nested('[', ']', kMaxJsonDepth + 1));
  EXPECT_EQ(e.file(), "body.json");
  EXPECT_NE(e.reason().find("deeper than 64"), std::string::npos) << e.reason();
  const auto f = Refusal(R"({"machine_id":"m","x":)" + Nested('[', ']', 100) + "}");
  EXPECT_EQ(f.field().rfind("x[0][0]", 0), 0u) << f.field();
  EXPECT_NE(f.field().find("…"), std::string::npos) << "a long path is shortened: " << f.field();
  const auto g = Refusal(R"({"a":{"b":[1,{"c":)" + Nested('[', ']', 3) + "}]}}",
                         JsonTextLimits{.max_depth = 4});
  EXPECT_EQ(g.field(), "a.b[1].c");  // the value at c is too deep
}

TEST(JsonText, HundredsOfThousandsOfLevelsAreRefusedWithoutRecursion) {
  for (const std::size_t depth : {60000u, 400000u, 2000000u}) {
    EXPECT_NO_FATAL_FAILURE(Refusal(R"({"notes":)" + Nested('[', ']', depth) + "}"));
    std::string objects;
    for (std::size_t i = 0; i < depth; ++i) objects += "{\"a\":";
    EXPECT_NO_FATAL_FAILURE(Refusal(objects + "1" + std::string(depth, '}')));
    // Unclosed: the refusal comes from the depth, before the end of the input.
    EXPECT_EQ(Refusal(std::string(depth, '[')).field().substr(0, 3), "[0]");
  }
}

TEST(JsonText, RepeatedKeysAreRefusedNamingTheKey) {
  EXPECT_EQ(Refusal(R"({"role":"viewer","role":"admin"})").field(), "role");
  const auto e = Refusal(R"({"a":[{"k":1},{"k":2,"k":3}]})");
  EXPECT_EQ(e.field(), "a[1].k");
  EXPECT_NE(e.reason().find("more than once"), std::string::npos);
  // The same key in sibling objects is fine.
  EXPECT_NO_THROW(ParseJsonText(R"([{"k":1},{"k":2}])", "doc"));
}

TEST(JsonText, ALongKeyIsShortenedBeforeACharacterNotInsideOne) {
  std::string key(63, 'k');
  key += "\xc3\xa9\xc3\xa9";  // "éé": the 64-byte cut falls inside the first é
  const auto e = Refusal("{\"" + key + "\":1e999}");
  EXPECT_EQ(e.field(), std::string(63, 'k'));
}

TEST(JsonText, NumbersBeyondADoubleAreRefusedNamingTheField) {
  EXPECT_EQ(Refusal(R"({"x":1e999})").field(), "x");
  EXPECT_EQ(Refusal(R"({"a":{"b":[0,-1e999]}})").field(), "a.b[1]");
  EXPECT_EQ(Refusal("[" + std::string(400, '9') + "]").field(), "[0]");
  EXPECT_NE(Refusal(R"({"x":1e999})").reason().find("does not fit a double"), std::string::npos);
  // Small magnitudes underflow to zero or a subnormal, as strtod reads them: not an error.
  EXPECT_EQ(ParseJsonText("1e-400", "doc"), json::parse("1e-400"));
}

TEST(JsonText, SyntaxErrorsNameTheLine) {
  const auto e = Refusal("{\n\"a\": 1,\n\"b\": ]\n}");
  EXPECT_EQ(e.line(), 3u);
  EXPECT_NE(e.reason().find("not valid JSON"), std::string::npos);
  EXPECT_EQ(Refusal("").reason().substr(0, 14), "not valid JSON");
  EXPECT_EQ(Refusal("{} {}").reason().substr(0, 14), "not valid JSON");
}

TEST(JsonText, TheTolerantFormDiscards) {
  EXPECT_TRUE(ParseJsonTextOrDiscarded(R"({"x":1e999})").is_discarded());
  EXPECT_TRUE(ParseJsonTextOrDiscarded(Nested('[', ']', 100000)).is_discarded());
  EXPECT_TRUE(ParseJsonTextOrDiscarded("{").is_discarded());
  EXPECT_EQ(ParseJsonTextOrDiscarded(R"({"a":[1]})"), json::parse(R"({"a":[1]})"));
}

}  // namespace
}  // namespace km::ingest
