// The parsed stored results: the same text answers the same document without parsing again, the
// bound on the texts' bytes drops the least recently used, a document too large is not kept, and
// a text that is not JSON is refused as before with nothing kept.
#include "server/measurements/parsed_results.h"

#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

std::string Doc(int n, std::size_t pad = 0) {
  return "{\"n\":" + std::to_string(n) + ",\"pad\":\"" + std::string(pad, 'x') + "\"}";
}

TEST(ParsedResults, TheSameTextIsParsedOnceAndGivesTheSameDocument) {
  ParsedResults cache;
  const auto a = cache.Parse(Doc(1));
  const auto b = cache.Parse(Doc(1));
  EXPECT_EQ(a.get(), b.get());  // kept: the second answer is the first document
  EXPECT_EQ((*a)["n"], 1);
  const auto c = cache.Parse(Doc(2));
  EXPECT_NE(a.get(), c.get());
  EXPECT_EQ((*c)["n"], 2);
  EXPECT_EQ(cache.size(), 2u);
  EXPECT_EQ(cache.text_bytes(), Doc(1).size() + Doc(2).size());
}

TEST(ParsedResults, TheLeastRecentlyUsedIsDroppedAtTheBound) {
  const std::size_t one = Doc(10, 90).size();  // documents 10 to 99 are all this long
  ParsedResults cache(12 * one + 5);           // twelve documents fit
  const auto first = cache.Parse(Doc(10, 90));
  for (int n = 11; n < 22; ++n) cache.Parse(Doc(n, 90));
  EXPECT_EQ(cache.size(), 12u);
  cache.Parse(Doc(10, 90));  // used again: now the newest
  cache.Parse(Doc(22, 90));  // drops document 11, the least recently used
  EXPECT_EQ(cache.size(), 12u);
  EXPECT_LE(cache.text_bytes(), 12 * one + 5);
  EXPECT_EQ(cache.Parse(Doc(10, 90)).get(), first.get());  // still kept
  const auto eleven = cache.Parse(Doc(11, 90));            // parsed again
  EXPECT_EQ((*eleven)["n"], 11);
  EXPECT_EQ(cache.size(), 12u);
}

TEST(ParsedResults, ALargeDocumentIsParsedButNotKeptAndBadTextIsRefused) {
  ParsedResults cache(1000);
  const auto big = cache.Parse(Doc(7, 200));  // over a tenth of the bound
  EXPECT_EQ((*big)["n"], 7);
  EXPECT_EQ(cache.size(), 0u);
  EXPECT_NE(cache.Parse(Doc(7, 200)).get(), big.get());
  EXPECT_THROW(cache.Parse("{\"n\": 1"), InvalidInput);
  EXPECT_THROW(cache.Parse("{\"n\": 1"), InvalidInput);  // refused again, not remembered
  EXPECT_EQ(cache.size(), 0u);
}

}  // namespace
}  // namespace km::server
