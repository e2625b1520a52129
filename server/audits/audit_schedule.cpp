#include "server/audits/audit_schedule.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "analysis/core/errors.h"
#include "ingest/iso8601.h"
#include "ingest/text_format.h"

namespace km::server {
namespace {

constexpr std::int64_t kDay = 86400;
// How far ahead a cron schedule's next run is searched: beyond the longest wait of a schedule
// that fires (29 February only: 8 years where a century year is no leap year, 2096 → 2104).
constexpr std::int64_t kHorizonDays = 9 * 366;

// The civil date (proleptic Gregorian) of a day number since 1970-01-01.
using Civil = ingest::CivilDate;
using ingest::CivilFromDays;

std::int64_t FloorDiv(std::int64_t a, std::int64_t b) {
  return a / b - ((a % b != 0) && ((a < 0) != (b < 0)));
}

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(cur);
  return out;
}

bool ParseNumber(const std::string& s, int& out) {
  if (s.empty() || s.size() > 9) return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

// One cron field into the set of allowed values lo…hi; `restricted` false for "*".
template <std::size_t N>
std::bitset<N> ParseCronField(const std::string& text, int lo, int hi, const std::string& name,
                              const std::string& field, bool* restricted) {
  const auto bad = [&](const std::string& why) {
    return InvalidInput("", 0, field,
                        "cron " + name + " field '" + text + "': " + why + " (values " +
                            std::to_string(lo) + "–" + std::to_string(hi) + ")");
  };
  std::bitset<N> set;
  if (restricted) *restricted = text != "*";
  for (const auto& item : Split(text, ',')) {
    const auto slash = item.find('/');
    const std::string range = item.substr(0, slash);
    int step = 1;
    if (slash != std::string::npos && (!ParseNumber(item.substr(slash + 1), step) || step < 1)) {
      throw bad("a step must be a whole number ≥ 1");
    }
    int a = lo, b = hi;
    if (range != "*") {
      const auto dash = range.find('-');
      if (!ParseNumber(range.substr(0, dash), a)) throw bad("'" + item + "' is not a value");
      b = a;
      if (dash != std::string::npos && !ParseNumber(range.substr(dash + 1), b)) {
        throw bad("'" + item + "' is not a range");
      }
      if (slash != std::string::npos && dash == std::string::npos) b = hi;
    }
    if (a < lo || b > hi || a > b) throw bad("'" + item + "' is out of range");
    for (int v = a; v <= b; v += step) set.set(static_cast<std::size_t>(v));
  }
  return set;
}

// Whether a cron schedule ever fires. A day of the week matches in every month (alone, or
// either day field when both are restricted); a day of the month alone only in the months that
// have it (29 February: in leap years).
bool Fires(const AuditSchedule& s) {
  if (s.weekdays_restricted) return s.weekdays.any();
  static constexpr std::size_t kLongest[13] = {0, 31, 29, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  for (std::size_t m = 1; m <= 12; ++m) {
    if (!s.months[m]) continue;
    for (std::size_t d = 1; d <= kLongest[m]; ++d) {
      if (s.days[d]) return true;
    }
  }
  return false;
}

AuditSchedule ParseCron(const std::string& text, const std::string& field) {
  std::istringstream in(text);
  std::vector<std::string> parts;
  for (std::string p; in >> p;) parts.push_back(p);
  if (parts.size() != 5) {
    throw InvalidInput("", 0, field,
                       "'" + text +
                           "' is neither \"every N s|m|h|d\" nor a cron expression of 5 fields "
                           "(minute hour day-of-month month day-of-week)");
  }
  AuditSchedule s;
  s.text = text;
  s.minutes = ParseCronField<60>(parts[0], 0, 59, "minute", field, nullptr);
  s.hours = ParseCronField<24>(parts[1], 0, 23, "hour", field, nullptr);
  s.days = ParseCronField<32>(parts[2], 1, 31, "day-of-month", field, &s.days_restricted);
  s.months = ParseCronField<13>(parts[3], 1, 12, "month", field, nullptr);
  const auto dow = ParseCronField<8>(parts[4], 0, 7, "day-of-week", field, &s.weekdays_restricted);
  for (std::size_t d = 0; d < 7; ++d) s.weekdays[d] = dow[d] || (d == 0 && dow[7]);
  if (!Fires(s)) {
    throw InvalidInput("", 0, field,
                       "'" + text +
                           "' never fires: none of its months has any of its days of the month "
                           "(e.g. 30 or 31 February, 31 April)");
  }
  return s;
}

AuditSchedule ParseEvery(const std::string& text, const std::string& field) {
  const std::string rest = text.substr(6);
  std::size_t digits = 0;
  while (digits < rest.size() && rest[digits] >= '0' && rest[digits] <= '9') ++digits;
  std::string unit = rest.substr(digits);
  while (!unit.empty() && unit.front() == ' ') unit.erase(0, 1);
  int n = 0;
  const std::int64_t scale = unit == "s"   ? 1
                             : unit == "m" ? 60
                             : unit == "h" ? 3600
                             : unit == "d" ? kDay
                                           : 0;
  if (!ParseNumber(rest.substr(0, digits), n) || n < 1 || scale == 0 || n * scale > 366 * kDay) {
    throw InvalidInput("", 0, field,
                       "'" + text +
                           "': an interval is \"every N\" with N ≥ 1 and a unit s, m, h or d, "
                           "at most 366 d (e.g. \"every 24h\", \"every 30m\")");
  }
  AuditSchedule s;
  s.text = text;
  s.every_s = n * scale;
  return s;
}

bool DayMatches(const AuditSchedule& s, std::int64_t day) {
  const Civil c = CivilFromDays(day);
  if (!s.months[c.month]) return false;
  const bool dom = s.days[c.day];
  const bool dow = s.weekdays[static_cast<std::size_t>(((day % 7) + 11) % 7)];  // 1970-01-01: Thu
  if (s.days_restricted && s.weekdays_restricted) return dom || dow;
  return dom && dow;
}

}  // namespace

AuditSchedule ParseAuditSchedule(const std::string& raw, const std::string& field) {
  const auto first = raw.find_first_not_of(" \t");
  const auto last = raw.find_last_not_of(" \t");
  const std::string text = first == std::string::npos ? "" : raw.substr(first, last - first + 1);
  if (text.empty() || text.size() > 200) {
    throw InvalidInput("", 0, field, "a schedule is \"every N s|m|h|d\" or a cron expression");
  }
  if (text.rfind("every ", 0) == 0) return ParseEvery(text, field);
  return ParseCron(text, field);
}

std::optional<std::int64_t> NextAuditRun(const AuditSchedule& s, std::int64_t after) {
  if (s.every_s > 0) return after + s.every_s;
  const std::int64_t start = FloorDiv(after, 60) * 60 + 60;  // the next whole minute
  const std::int64_t first_day = FloorDiv(start, kDay);
  for (std::int64_t day = first_day; day < first_day + kHorizonDays; ++day) {
    if (!DayMatches(s, day)) continue;
    for (std::size_t h = 0; h < 24; ++h) {
      if (!s.hours[h]) continue;
      for (std::size_t m = 0; m < 60; ++m) {
        const std::int64_t t = day * kDay + static_cast<std::int64_t>(h * 3600 + m * 60);
        if (s.minutes[m] && t >= start) return t;
      }
    }
  }
  return std::nullopt;
}

std::string IsoFromUnixSeconds(std::int64_t t) {
  const std::int64_t day = FloorDiv(t, kDay);
  const std::int64_t sec = t - day * kDay;
  const Civil c = CivilFromDays(day);
  char buf[128];
  std::snprintf(buf, sizeof buf, "%04lld-%02u-%02uT%02lld:%02lld:%02lldZ",
                static_cast<long long>(c.year), c.month, c.day, static_cast<long long>(sec / 3600),
                static_cast<long long>(sec / 60 % 60), static_cast<long long>(sec % 60));
  return buf;
}

std::optional<std::int64_t> UnixSecondsFromIso(const std::string& text) {
  const auto s = ingest::Iso8601EpochSeconds(text);
  if (!s || !std::isfinite(*s)) return std::nullopt;
  return static_cast<std::int64_t>(std::floor(*s));
}

}  // namespace km::server
