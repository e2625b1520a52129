// ISO 8601 dates and date-times as measurement files and queries write them:
//
//   YYYY-MM-DD[(T| )hh:mm[:ss[.f…]][Z|±hh[:]mm]]
//
// (a time zone only after a time, a fraction only after seconds). A hand-written scanner:
// linear in the text, no recursion, and texts longer than kMaxIso8601Length are refused before
// they are looked at. Only the syntax is checked here; ranges (month 1–12, …) are the caller's.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace km::ingest {

inline constexpr std::size_t kMaxIso8601Length = 64;

struct Iso8601Time {
  int year = 0, month = 0, day = 0;
  bool has_time = false;
  int hour = 0, minute = 0;
  bool has_seconds = false;
  int second = 0;
  std::string fraction;  // digits after the decimal point (empty: none)
  enum class Zone { kNone, kUtc, kOffset } zone = Zone::kNone;
  int offset_sign = 1;  // +1 or −1 (kOffset only)
  int offset_hours = 0, offset_minutes = 0;
};

// The parts of an ISO 8601 text of the syntax above; nullopt when the text does not follow it
// exactly or is longer than kMaxIso8601Length.
std::optional<Iso8601Time> ParseIso8601(std::string_view text);

}  // namespace km::ingest

namespace km::ingest {

// Seconds since 1970-01-01T00:00:00Z of an ISO 8601 text (a text without a zone counts as UTC;
// a date alone as its midnight); nullopt when the text is not ISO 8601 or a field is out of
// range.
std::optional<double> Iso8601EpochSeconds(std::string_view text);

// Microseconds since the Unix epoch as "YYYY-MM-DDTHH:MM:SS.ffffffZ".
std::string UtcIso8601FromMicros(std::int64_t t_us);

}  // namespace km::ingest
