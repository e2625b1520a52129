#include "server/base/time_util.h"

#include <chrono>
#include <cstdio>
#include <ctime>

#include "ingest/iso8601.h"

namespace km::server {

std::string NowUtcIso8601() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::optional<std::string> NormaliseIso8601(const std::string& text) {
  const auto p = ingest::ParseIso8601(text);  // nullopt beyond kMaxIso8601Length characters
  if (!p) return std::nullopt;
  std::tm tm{};
  tm.tm_year = p->year - 1900;
  tm.tm_mon = p->month - 1;
  tm.tm_mday = p->day;
  tm.tm_hour = p->hour;
  tm.tm_min = p->minute;
  tm.tm_sec = p->second;
  if (tm.tm_mon < 0 || tm.tm_mon > 11 || tm.tm_mday < 1 || tm.tm_mday > 31 || tm.tm_hour > 23 ||
      tm.tm_min > 59 || tm.tm_sec > 60) {
    return std::nullopt;
  }
  std::time_t t = timegm(&tm);
  if (p->zone == ingest::Iso8601Time::Zone::kOffset) {
    t -= p->offset_sign * (p->offset_hours * 60 + p->offset_minutes) * 60;
  }
  std::tm out{};
  // A zone offset may move a time out of the years 0000–9999, which have no ISO 8601 text of
  // this form: not a time (its text would not read back).
  if (!gmtime_r(&t, &out) || out.tm_year < -1900 || out.tm_year > 9999 - 1900) {
    return std::nullopt;
  }
  char buf[40];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d", out.tm_year + 1900,
                out.tm_mon + 1, out.tm_mday, out.tm_hour, out.tm_min, out.tm_sec);
  std::string s = buf;
  if (p->has_seconds && !p->fraction.empty()) s += "." + p->fraction.substr(0, 6);
  return s + "Z";
}

}  // namespace km::server
