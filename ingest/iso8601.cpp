#include "ingest/iso8601.h"

#include <cstdio>
#include <ctime>
#include <string>

namespace km::ingest {
namespace {

bool IsDigit(char c) {
  return c >= '0' && c <= '9';
}

// Reads exactly n digits at pos as a number; false (pos unchanged) when they are not there.
bool Digits(std::string_view s, std::size_t& pos, std::size_t n, int& out) {
  if (s.size() - pos < n) return false;
  int v = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const char c = s[pos + k];
    if (!IsDigit(c)) return false;
    v = 10 * v + (c - '0');
  }
  pos += n;
  out = v;
  return true;
}

bool Char(std::string_view s, std::size_t& pos, char c) {
  if (pos < s.size() && s[pos] == c) {
    ++pos;
    return true;
  }
  return false;
}

}  // namespace

std::optional<Iso8601Time> ParseIso8601(std::string_view s) {
  if (s.size() > kMaxIso8601Length) return std::nullopt;
  Iso8601Time t;
  std::size_t pos = 0;
  if (!Digits(s, pos, 4, t.year) || !Char(s, pos, '-') || !Digits(s, pos, 2, t.month) ||
      !Char(s, pos, '-') || !Digits(s, pos, 2, t.day)) {
    return std::nullopt;
  }
  if (pos == s.size()) return t;
  // The time: [T ]hh:mm, then optional :ss with an optional fraction.
  if (s[pos] != 'T' && s[pos] != ' ') return std::nullopt;
  ++pos;
  if (!Digits(s, pos, 2, t.hour) || !Char(s, pos, ':') || !Digits(s, pos, 2, t.minute)) {
    return std::nullopt;
  }
  t.has_time = true;
  if (Char(s, pos, ':')) {
    if (!Digits(s, pos, 2, t.second)) return std::nullopt;
    t.has_seconds = true;
    if (Char(s, pos, '.')) {
      const std::size_t start = pos;
      while (pos < s.size() && IsDigit(s[pos])) ++pos;
      if (pos == start) return std::nullopt;
      t.fraction.assign(s.substr(start, pos - start));
    }
  }
  if (pos == s.size()) return t;
  // The zone: Z or ±hh[:]mm, and nothing after it.
  if (Char(s, pos, 'Z')) {
    t.zone = Iso8601Time::Zone::kUtc;
  } else if (s[pos] == '+' || s[pos] == '-') {
    t.offset_sign = s[pos] == '+' ? 1 : -1;
    ++pos;
    if (!Digits(s, pos, 2, t.offset_hours)) return std::nullopt;
    Char(s, pos, ':');
    if (!Digits(s, pos, 2, t.offset_minutes)) return std::nullopt;
    t.zone = Iso8601Time::Zone::kOffset;
  } else {
    return std::nullopt;
  }
  if (pos != s.size()) return std::nullopt;
  return t;
}

}  // namespace km::ingest

namespace km::ingest {

std::optional<double> Iso8601EpochSeconds(std::string_view text) {
  const auto t = ParseIso8601(text);
  if (!t) return std::nullopt;
  if (t->month < 1 || t->month > 12 || t->day < 1 || t->day > 31 || t->hour > 23 ||
      t->minute > 59 || t->second > 60 || t->offset_hours > 23 || t->offset_minutes > 59)
    return std::nullopt;
  // Days from the civil date (proleptic Gregorian), H. Hinnant's algorithm.
  const long y = t->year - (t->month <= 2 ? 1 : 0);
  const long era = (y >= 0 ? y : y - 399) / 400;
  const long yoe = y - era * 400;
  const long mp = (t->month + 9) % 12;
  const long doy = (153 * mp + 2) / 5 + t->day - 1;
  const long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  const long days = era * 146097 + doe - 719468;
  double s = static_cast<double>(days) * 86400.0 + t->hour * 3600.0 + t->minute * 60.0 + t->second;
  if (!t->fraction.empty()) s += std::stod("0." + t->fraction.substr(0, 15));
  if (t->zone == Iso8601Time::Zone::kOffset)
    s -= t->offset_sign * (t->offset_hours * 3600.0 + t->offset_minutes * 60.0);
  return s;
}

std::string UtcIso8601FromMicros(std::int64_t t_us) {
  std::int64_t secs = t_us / 1000000;
  std::int64_t frac = t_us % 1000000;
  if (frac < 0) {
    frac += 1000000;
    --secs;
  }
  const auto t = static_cast<std::time_t>(secs);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[48];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[64];
  std::snprintf(out, sizeof out, "%s.%06lldZ", buf, static_cast<long long>(frac));
  return out;
}

}  // namespace km::ingest
