// Accuracy-audit schedules (server/audits/audit_schedule.h): intervals and 5-field cron expressions
// in UTC, with the exact next run times at the edges (the due minute itself, weekends, month and
// year ends, 29 February also across 2100, day-of-month OR day-of-week, Sunday as 0 and 7) and
// the errors of malformed schedules and of schedules that never fire, naming the field and the
// cron field.
#include "server/audits/audit_schedule.h"

#include <gtest/gtest.h>

#include <string>

#include "analysis/core/errors.h"

namespace km::server::test {
namespace {

std::int64_t T(const std::string& iso) {
  const auto t = UnixSecondsFromIso(iso);
  EXPECT_TRUE(t) << iso;
  return t.value_or(0);
}

std::string Next(const std::string& schedule, const std::string& after) {
  const auto t = NextAuditRun(ParseAuditSchedule(schedule), T(after));
  return t ? IsoFromUnixSeconds(*t) : "none";
}

TEST(AuditSchedule, IntervalsAddTheirLengthToTheTimeGiven) {
  EXPECT_EQ(Next("every 24h", "2026-11-27T03:12:05Z"), "2026-11-28T03:12:05Z");
  EXPECT_EQ(Next("every 30m", "2026-11-27T23:45:00Z"), "2026-11-28T00:15:00Z");
  EXPECT_EQ(Next("every 2s", "2026-11-27T03:12:59Z"), "2026-11-27T03:13:01Z");
  EXPECT_EQ(Next("every 7d", "2026-12-30T00:00:00Z"), "2027-01-06T00:00:00Z");
  EXPECT_EQ(Next("  every 1 h ", "2026-11-27T03:00:00Z"), "2026-11-27T04:00:00Z");
  EXPECT_EQ(ParseAuditSchedule("every 366d").every_s, 366 * 86400);
}

TEST(AuditSchedule, CronWeekdaysAtSixSkipTheWeekendAndTheDueMinuteItself) {
  // 2026-11-27 is a Friday.
  EXPECT_EQ(Next("0 6 * * 1-5", "2026-11-27T03:12:00Z"), "2026-11-27T06:00:00Z");
  EXPECT_EQ(Next("0 6 * * 1-5", "2026-11-27T06:00:00Z"), "2026-11-30T06:00:00Z");
  EXPECT_EQ(Next("0 6 * * 1-5", "2026-11-27T05:59:59Z"), "2026-11-27T06:00:00Z");
}

TEST(AuditSchedule, CronStepsListsAndRanges) {
  EXPECT_EQ(Next("*/15 * * * *", "2026-11-27T03:12:34Z"), "2026-11-27T03:15:00Z");
  EXPECT_EQ(Next("*/15 * * * *", "2026-11-27T23:50:00Z"), "2026-11-28T00:00:00Z");
  EXPECT_EQ(Next("5,10-20/5 3 * * *", "2026-11-27T03:06:00Z"), "2026-11-27T03:10:00Z");
  EXPECT_EQ(Next("5,10-20/5 3 * * *", "2026-11-27T03:20:00Z"), "2026-11-28T03:05:00Z");
  EXPECT_EQ(Next("0 0 1 1 *", "2026-12-31T23:59:59Z"), "2027-01-01T00:00:00Z");
  EXPECT_EQ(Next("0 12 * 2 *", "2026-11-27T00:00:00Z"), "2027-02-01T12:00:00Z");
}

TEST(AuditSchedule, CronLeapDaysImpossibleDatesAndDayFieldsEitherMatching) {
  EXPECT_EQ(Next("0 0 29 2 *", "2026-03-01T00:00:00Z"), "2028-02-29T00:00:00Z");
  EXPECT_EQ(Next("0 0 31 * *", "2026-11-27T00:00:00Z"), "2026-12-31T00:00:00Z");
  // Both day fields restricted: the 1st of the month or a Sunday, whichever comes first.
  EXPECT_EQ(Next("0 12 1 * 0", "2026-11-27T00:00:00Z"), "2026-11-29T12:00:00Z");
  EXPECT_EQ(Next("0 12 1 * 0", "2026-11-29T12:00:00Z"), "2026-12-01T12:00:00Z");
  EXPECT_EQ(Next("30 8 * * 7", "2026-11-27T00:00:00Z"), "2026-11-29T08:30:00Z");
  EXPECT_EQ(Next("30 8 * * 0", "2026-11-27T00:00:00Z"), "2026-11-29T08:30:00Z");
}

std::string ErrorOf(const std::string& schedule) {
  try {
    ParseAuditSchedule(schedule);
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "schedule") << schedule;
    return e.reason();
  }
  return "accepted";
}

TEST(AuditSchedule, MalformedSchedulesNameTheFieldAndThePart) {
  EXPECT_NE(ErrorOf("every 0h").find("N ≥ 1"), std::string::npos);
  EXPECT_NE(ErrorOf("every 5x").find("unit"), std::string::npos);
  EXPECT_NE(ErrorOf("every 367d").find("366 d"), std::string::npos);
  EXPECT_NE(ErrorOf("61 * * * *").find("minute"), std::string::npos);
  EXPECT_NE(ErrorOf("* 24 * * *").find("hour"), std::string::npos);
  EXPECT_NE(ErrorOf("* * 0 * *").find("day-of-month"), std::string::npos);
  EXPECT_NE(ErrorOf("* * * 13 *").find("month"), std::string::npos);
  EXPECT_NE(ErrorOf("* * * * 8").find("day-of-week"), std::string::npos);
  EXPECT_NE(ErrorOf("*/0 * * * *").find("step"), std::string::npos);
  EXPECT_NE(ErrorOf("5-3 * * * *").find("out of range"), std::string::npos);
  EXPECT_NE(ErrorOf("* * * *").find("5 fields"), std::string::npos);
  EXPECT_NE(ErrorOf("").find("cron"), std::string::npos);
  EXPECT_NE(ErrorOf("daily").find("5 fields"), std::string::npos);
}

TEST(AuditSchedule, AScheduleThatNeverFiresIsRefusedNamingTheField) {
  for (const char* never : {"0 0 31 2 *", "0 0 30 2 *", "0 0 30,31 2 *", "0 0 31 4 *",
                            "0 0 31 4,6,9,11 *", "15 3 30-31 2 *", "0 0 31 2,4 *"}) {
    const std::string why = ErrorOf(never);
    EXPECT_NE(why.find("never fires"), std::string::npos) << never << ": " << why;
    EXPECT_NE(why.find(never), std::string::npos) << why;
  }
  // Each of these fires: a day some month has, a weekday (alone or either day field).
  EXPECT_EQ(Next("0 0 31 * *", "2026-11-01T00:00:00Z"), "2026-12-31T00:00:00Z");
  EXPECT_EQ(Next("0 0 31 2,3 *", "2026-11-01T00:00:00Z"), "2027-03-31T00:00:00Z");
  EXPECT_EQ(Next("0 0 30 4 *", "2026-11-01T00:00:00Z"), "2027-04-30T00:00:00Z");
  EXPECT_EQ(Next("0 0 31 2 1", "2026-11-01T00:00:00Z"), "2027-02-01T00:00:00Z");  // a Monday
  EXPECT_EQ(Next("0 0 * 2 1", "2026-11-01T00:00:00Z"), "2027-02-01T00:00:00Z");
}

TEST(AuditSchedule, TwentyNinthOfFebruaryWaitsAcrossACenturyThatIsNoLeapYear) {
  // 2100 is no leap year: after 29 February 2096 the next is 29 February 2104, 8 years on.
  EXPECT_EQ(Next("0 0 29 2 *", "2096-02-29T00:00:00Z"), "2104-02-29T00:00:00Z");
  EXPECT_EQ(Next("0 0 29 2 *", "2097-01-01T00:00:00Z"), "2104-02-29T00:00:00Z");
  EXPECT_EQ(Next("59 23 29 2 *", "2099-12-31T23:59:59Z"), "2104-02-29T23:59:00Z");
  // 2000 was one (divisible by 400).
  EXPECT_EQ(Next("0 0 29 2 *", "1996-03-01T00:00:00Z"), "2000-02-29T00:00:00Z");
}

TEST(AuditSchedule, IsoTextsAndUnixSecondsRoundTrip) {
  EXPECT_EQ(IsoFromUnixSeconds(0), "1970-01-01T00:00:00Z");
  EXPECT_EQ(IsoFromUnixSeconds(T("2028-02-29T23:59:59Z")), "2028-02-29T23:59:59Z");
  EXPECT_EQ(T("2026-11-27T03:12:00Z"), 1795749120);
  EXPECT_FALSE(UnixSecondsFromIso("yesterday"));
}

}  // namespace
}  // namespace km::server::test
