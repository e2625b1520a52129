#include "api/http_target.h"

#include <gtest/gtest.h>

namespace km::api {
namespace {

TEST(ParseTarget, DecodesPathAndQuery) {
  std::string error;
  const auto t = ParseTarget("/api/v1/x%20y?from=2024-01-01T00%3A00%3A00Z&q=a+b&flag&=v", error);
  ASSERT_TRUE(t) << error;
  EXPECT_EQ(t->path, "/api/v1/x y");
  EXPECT_EQ(t->query.find("from")->second, "2024-01-01T00:00:00Z");
  EXPECT_EQ(t->query.find("q")->second, "a b");
  EXPECT_EQ(t->query.find("flag")->second, "");
  EXPECT_EQ(t->query.find("")->second, "v");
}

TEST(ParseTarget, RefusesWhatCannotBeShownOrStored) {
  for (const char* bad : {"/static/index.html%00.png", "/a%0a", "/a%7f", "/a%zz", "/a%4", "x/y", "",
                          "/?k=%C0%AF", "/%ED%A0%80", "/?%FF=1"}) {
    std::string error;
    EXPECT_FALSE(ParseTarget(bad, error)) << bad;
    EXPECT_FALSE(error.empty()) << bad;
  }
}

TEST(IsUtf8, StrictDecoding) {
  EXPECT_TRUE(IsUtf8("plain"));
  EXPECT_TRUE(IsUtf8("\xC2\xB5m"));          // µm
  EXPECT_TRUE(IsUtf8("\xE2\x82\xAC"));       // €
  EXPECT_TRUE(IsUtf8("\xF0\x9F\x98\x80"));   // U+1F600
  EXPECT_TRUE(IsUtf8("\xF4\x8F\xBF\xBF"));   // U+10FFFF
  EXPECT_FALSE(IsUtf8("\xC0\xAF"));          // overlong '/'
  EXPECT_FALSE(IsUtf8("\xE0\x80\xAF"));      // overlong 3-byte
  EXPECT_FALSE(IsUtf8("\xF0\x80\x80\xAF"));  // overlong 4-byte
  EXPECT_FALSE(IsUtf8("\xED\xA0\x80"));      // surrogate U+D800
  EXPECT_FALSE(IsUtf8("\xF4\x90\x80\x80"));  // above U+10FFFF
  EXPECT_FALSE(IsUtf8("\xE2\x82"));          // truncated
  EXPECT_FALSE(IsUtf8("\x80"));              // lone continuation
  EXPECT_FALSE(IsUtf8("\xFF"));
}

}  // namespace
}  // namespace km::api
