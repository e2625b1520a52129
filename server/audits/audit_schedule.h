// When an accuracy audit runs: "every N s|m|h|d" (an interval from the previous run) or a
// 5-field cron expression in UTC ("minute hour day-of-month month day-of-week"; each field
// "*", a number, a range "a-b", a step "*/n" or "a-b/n", or a list of those separated by
// commas; day-of-week 0–7 with 0 and 7 Sunday; when both day fields are restricted a day
// matching either runs, as cron does). Times are whole seconds since the Unix epoch (UTC).
#pragma once

#include <bitset>
#include <cstdint>
#include <optional>
#include <string>

namespace km::server {

struct AuditSchedule {
  std::string text;          // as given (trimmed)
  std::int64_t every_s = 0;  // > 0: an interval schedule
  // Cron fields (every_s == 0): allowed values.
  std::bitset<60> minutes;
  std::bitset<24> hours;
  std::bitset<32> days;     // 1–31
  std::bitset<13> months;   // 1–12
  std::bitset<7> weekdays;  // 0 = Sunday
  bool days_restricted = false, weekdays_restricted = false;
};

// Parses a schedule; km::InvalidInput naming `field` (and the cron field) when it is not one,
// or when it never fires ("0 0 31 2 *", "0 0 30 2 *", "0 0 31 4 *"; "0 0 29 2 *" fires in leap
// years). Intervals: 1 s to 366 d (seconds are meant for tests and demonstrations).
AuditSchedule ParseAuditSchedule(const std::string& text, const std::string& field = "schedule");

// The first run time strictly after `after` (Unix seconds): after + the interval, or the next
// whole minute the cron fields match (searched up to 9 years ahead, beyond the longest wait of
// a schedule that fires: 29 February across 2100; nullopt when none).
std::optional<std::int64_t> NextAuditRun(const AuditSchedule& schedule, std::int64_t after);

// Unix seconds as "YYYY-MM-DDTHH:MM:SSZ", and back (nullopt when not ISO 8601).
std::string IsoFromUnixSeconds(std::int64_t t);
std::optional<std::int64_t> UnixSecondsFromIso(const std::string& text);

}  // namespace km::server
