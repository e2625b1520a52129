// NormaliseIso8601 (server/base/time_util.h): the same answers as the regular expression that used
// to define it, and very long texts (100 KB query values) refused without deep recursion.
#include "server/base/time_util.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <ctime>
#include <random>
#include <regex>
#include <string>

namespace km::server {
namespace {

// The former implementation, kept as the reference (short texts only).
std::optional<std::string> Reference(const std::string& text) {
  static const std::regex re(
      R"(^(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2})(\.\d+)?)?(Z|([+-])(\d{2}):?(\d{2}))?)?$)");
  std::smatch m;
  if (!std::regex_match(text, m, re)) return std::nullopt;
  std::tm tm{};
  tm.tm_year = std::stoi(m[1]) - 1900;
  tm.tm_mon = std::stoi(m[2]) - 1;
  tm.tm_mday = std::stoi(m[3]);
  tm.tm_hour = m[4].matched ? std::stoi(m[4]) : 0;
  tm.tm_min = m[5].matched ? std::stoi(m[5]) : 0;
  tm.tm_sec = m[6].matched ? std::stoi(m[6]) : 0;
  if (tm.tm_mon < 0 || tm.tm_mon > 11 || tm.tm_mday < 1 || tm.tm_mday > 31 || tm.tm_hour > 23 ||
      tm.tm_min > 59 || tm.tm_sec > 60) {
    return std::nullopt;
  }
  std::time_t t = timegm(&tm);
  if (m[9].matched) {
    const int off = (std::stoi(m[10]) * 60 + std::stoi(m[11])) * 60;
    t -= (m[9] == "+" ? off : -off);
  }
  std::tm out{};
  gmtime_r(&t, &out);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &out);
  std::string s = buf;
  if (m[7].matched) s += m[7].str().substr(0, 7);
  return s + "Z";
}

TEST(TimeUtil, NormalisesLikeBefore) {
  EXPECT_EQ(NormaliseIso8601("2026-11-20T10:00:00+01:00"), "2026-11-20T09:00:00Z");
  EXPECT_EQ(NormaliseIso8601("2026-11-20"), "2026-11-20T00:00:00Z");
  EXPECT_EQ(NormaliseIso8601("2026-11-20 23:30-02:30"), "2026-11-21T02:00:00Z");
  EXPECT_EQ(NormaliseIso8601("2026-11-20T23:30:59.123456789Z"), "2026-11-20T23:30:59.123456Z");
  EXPECT_EQ(NormaliseIso8601("2026-12-31T23:59:60Z"), "2027-01-01T00:00:00Z");
  EXPECT_FALSE(NormaliseIso8601("2026-13-01"));
  EXPECT_FALSE(NormaliseIso8601("2026-11-20T24:00"));
  EXPECT_FALSE(NormaliseIso8601("soon"));
  std::mt19937 rng(7);
  const std::string alphabet = "0123456789-T :.Z+";
  const std::vector<std::string> seeds = {"2026-11-20",
                                          "1999-12-31T23:59",
                                          "2026-02-29 10:00:00",
                                          "2026-11-20T10:00:00.25Z",
                                          "2026-01-01T00:30-02:30",
                                          "2026-11-20T10:00:00.1234567+0100"};
  int valid = 0;
  for (int n = 0; n < 20000; ++n) {
    std::string s = seeds[rng() % seeds.size()];
    for (int e = 0; e < 2; ++e) {
      const std::size_t at = rng() % s.size();
      if (rng() % 2) {
        s[at] = alphabet[rng() % alphabet.size()];
      } else {
        s.erase(at, 1);
      }
    }
    const auto ref = Reference(s);
    valid += ref.has_value();
    // Years before 1000 were written with fewer than four digits (a text that did not read
    // back); they are written with four now.
    if (ref && ref->find('-') != 4) continue;
    ASSERT_EQ(NormaliseIso8601(s), ref) << "'" << s << "'";
  }
  EXPECT_GT(valid, 1000);
}

// A normalised time is itself a time that normalises to the same text: times whose UTC year
// leaves 0000–9999 (a zone offset at either end of the calendar) are not times.
TEST(TimeUtil, NormalisedTimesStayFourDigitYears) {
  EXPECT_FALSE(NormaliseIso8601("9999-12-31T23:09-0800"));
  EXPECT_FALSE(NormaliseIso8601("0000-01-01T00:30+01:00"));
  EXPECT_EQ(NormaliseIso8601("9999-12-31T23:09+0800"), "9999-12-31T15:09:00Z");
  EXPECT_EQ(NormaliseIso8601("0000-01-01T10:00+01:00"), "0000-01-01T09:00:00Z");
  EXPECT_EQ(NormaliseIso8601("0999-03-04 05:06:07.5"), "0999-03-04T05:06:07.5Z");
  std::mt19937 rng(11);
  const auto pick = [&](unsigned n) { return static_cast<unsigned>(rng() % n); };
  for (int n = 0; n < 20000; ++n) {
    char text[40];
    const unsigned year = pick(3) == 0 ? (pick(2) ? 9999u : 0u) : pick(10000);
    std::snprintf(text, sizeof text, "%04u-%02u-%02uT%02u:%02u:%02u%c%02u:%02u", year, 1 + pick(12),
                  1 + pick(31), pick(24), pick(60), pick(61), pick(2) ? '+' : '-', pick(100),
                  pick(100));
    const auto t = NormaliseIso8601(text);
    if (!t) continue;
    ASSERT_EQ(NormaliseIso8601(*t), t) << text;
  }
}

TEST(TimeUtil, HugeTextsAreNotTimes) {
  EXPECT_FALSE(NormaliseIso8601(std::string(110'000, '1')));
  EXPECT_FALSE(NormaliseIso8601("2026-11-20T10:00:00." + std::string(110'000, '7')));
  EXPECT_FALSE(NormaliseIso8601("2026-11-20T10:00:00." + std::string(45, '7')));  // 65 chars
  EXPECT_TRUE(NormaliseIso8601("2026-11-20T10:00:00." + std::string(44, '7')));   // 64 chars
}

}  // namespace
}  // namespace km::server
