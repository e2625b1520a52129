// ISO 8601 scanner (ingest/iso8601.h): the syntax the product has always accepted, checked
// against the regular expression that used to define it, and very long texts refused quickly
// (they used to overflow the stack of std::regex).
#include "ingest/iso8601.h"

#include <gtest/gtest.h>

#include <random>
#include <regex>
#include <string>

#include "analysis/core/errors.h"
#include "ingest/dbb_parser.h"

namespace km::ingest {
namespace {

// The former definition, kept here as the reference (short texts only).
bool ReferenceAccepts(const std::string& s) {
  static const std::regex re(
      R"(^\d{4}-\d{2}-\d{2}([T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}:?\d{2})?)?$)");
  return std::regex_match(s, re);
}

TEST(Iso8601, ReadsEveryPart) {
  const auto t = ParseIso8601("2026-11-20T23:30:15.123456789-02:30");
  ASSERT_TRUE(t);
  EXPECT_EQ(t->year, 2026);
  EXPECT_EQ(t->month, 11);
  EXPECT_EQ(t->day, 20);
  EXPECT_TRUE(t->has_time);
  EXPECT_EQ(t->hour, 23);
  EXPECT_EQ(t->minute, 30);
  EXPECT_TRUE(t->has_seconds);
  EXPECT_EQ(t->second, 15);
  EXPECT_EQ(t->fraction, "123456789");
  EXPECT_EQ(t->zone, Iso8601Time::Zone::kOffset);
  EXPECT_EQ(t->offset_sign, -1);
  EXPECT_EQ(t->offset_hours, 2);
  EXPECT_EQ(t->offset_minutes, 30);

  const auto d = ParseIso8601("2026-01-02");
  ASSERT_TRUE(d);
  EXPECT_FALSE(d->has_time);
  EXPECT_EQ(d->zone, Iso8601Time::Zone::kNone);
  const auto z = ParseIso8601("2026-01-02 03:04Z");
  ASSERT_TRUE(z);
  EXPECT_FALSE(z->has_seconds);
  EXPECT_EQ(z->zone, Iso8601Time::Zone::kUtc);
  const auto o = ParseIso8601("2026-01-02T03:04:05+0100");
  ASSERT_TRUE(o);
  EXPECT_EQ(o->offset_sign, 1);
  EXPECT_EQ(o->offset_hours, 1);
  EXPECT_EQ(o->offset_minutes, 0);
}

TEST(Iso8601, AcceptsExactlyWhatTheFormerExpressionAccepted) {
  const std::vector<std::string> cases = {
      "2026-11-20",
      "2026-11-20T10:00",
      "2026-11-20 10:00",
      "2026-11-20T10:00:00",
      "2026-11-20T10:00:00.5",
      "2026-11-20T10:00:00.",
      "2026-11-20T10:00.5",
      "2026-11-20T10:00Z",
      "2026-11-20T10:00:00Z",
      "2026-11-20T10:00:00.123Z",
      "2026-11-20T10:00+01:00",
      "2026-11-20T10:00:00-0130",
      "2026-11-20T10:00:00+01",
      "2026-11-20T10:00:00+1:00",
      "2026-11-20T10:00:00+01::00",
      "2026-11-20Z",
      "2026-11-20+01:00",
      "2026-11-20T",
      "2026-11-20T10",
      "2026-11-20T10:0",
      "2026-11-20T10:00:0",
      "2026-11-20t10:00",
      "2026-11-20T10:00:00z",
      "2026-11-20T10:00:00Z ",
      " 2026-11-20",
      "2026-1-20",
      "202-11-20",
      "20261-11-20",
      "2026/11/20",
      "2026-13-45",  // ranges are not the scanner's business
      "",
      "soon",
      "2026-11-20T10:00:00\n",
  };
  for (const auto& c : cases) {
    EXPECT_EQ(ParseIso8601(c).has_value(), ReferenceAccepts(c)) << "'" << c << "'";
  }
  // Random mutations of valid times: insert, delete or replace characters.
  const std::string alphabet = "0123456789-T :.Z+x";
  const std::vector<std::string> seeds = {"2026-11-20",
                                          "2026-11-20T10:00",
                                          "2026-11-20 10:00:00",
                                          "2026-11-20T10:00:00.25Z",
                                          "2026-11-20T10:00-02:30",
                                          "2026-11-20T10:00:00+0100"};
  std::mt19937 rng(20260301);
  int accepted = 0;
  for (int n = 0; n < 20000; ++n) {
    std::string s = seeds[rng() % seeds.size()];
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits; ++e) {
      const char c = alphabet[rng() % alphabet.size()];
      const std::size_t at = rng() % (s.size() + 1);
      switch (rng() % 3) {
        case 0:
          s.insert(at, 1, c);
          break;
        case 1:
          if (at < s.size()) s.erase(at, 1);
          break;
        default:
          if (at < s.size()) s[at] = c;
      }
    }
    const bool ref = ReferenceAccepts(s);
    accepted += ref;
    ASSERT_EQ(ParseIso8601(s).has_value(), ref) << "'" << s << "'";
  }
  EXPECT_GT(accepted, 1000);  // the mutations reach both answers
}

TEST(Iso8601, RefusesLongTextsWithoutLookingAtThem) {
  std::string fraction = "2026-11-20T10:00:00.";
  fraction.append(kMaxIso8601Length - fraction.size(), '1');
  EXPECT_TRUE(ParseIso8601(fraction));
  EXPECT_FALSE(ParseIso8601(fraction + "1"));
  EXPECT_FALSE(ParseIso8601(std::string(1'000'000, '1')));
  EXPECT_FALSE(ParseIso8601("2026-11-20T10:00:00." + std::string(200'000, '5')));
}

std::string DbbWithTimestamp(const std::string& ts) {
  std::string s =
      "# format: kinemetric-dbb/1\n"
      "# machine_id: vmc-1\n"
      "# test_id: xy-150\n"
      "# direction: ccw\n"
      "# bar_length_mm: 150\n"
      "# centre_mm: 10, 20, 30\n"
      "# feed_mm_min: 1000\n"
      "# timestamp: " +
      ts +
      "\n"
      "angle_deg,dr_um\n";
  for (int i = 0; i < 36; ++i) s += std::to_string(10 * i) + "," + std::to_string(0.1 * i) + "\n";
  return s;
}

TEST(Iso8601, DbbFileWithAHugeTimestampIsRefusedNamingTheField) {
  EXPECT_EQ(ParseDbb(DbbWithTimestamp("2026-11-20T10:00:00.5+01:00"), "ok.dbb").timestamp,
            "2026-11-20T10:00:00.5+01:00");
  for (const std::size_t n : {std::size_t{45}, std::size_t{1'000}, std::size_t{4'000}}) {
    const std::string ts = "2026-11-20T10:00:00." + std::string(n, '1');
    try {
      ParseDbb(DbbWithTimestamp(ts), "long.dbb");
      ADD_FAILURE() << "accepted a timestamp of " << ts.size() << " characters";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "long.dbb");
      EXPECT_EQ(e.line(), 8u);
      EXPECT_EQ(e.field(), "timestamp");
      EXPECT_LT(std::string(e.what()).size(), 300u) << "the message repeats the whole value";
    }
  }
  // Far longer values (they used to overflow the stack): refused, whichever check sees them
  // first (the line length of the text reader, or the timestamp's own limit).
  for (const std::size_t n : {std::size_t{40'000}, std::size_t{100'000}}) {
    const std::string ts = "2026-11-20T10:00:00." + std::string(n, '1');
    try {
      ParseDbb(DbbWithTimestamp(ts), "long.dbb");
      ADD_FAILURE() << "accepted a timestamp of " << ts.size() << " characters";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.file(), "long.dbb");
      EXPECT_EQ(e.line(), 8u);
      EXPECT_LT(std::string(e.what()).size(), 300u) << "the message repeats the whole value";
    }
  }
}

}  // namespace
}  // namespace km::ingest
