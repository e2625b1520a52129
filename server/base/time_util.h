// Time stamps as UTC ISO 8601 text ("2026-11-21T21:05:24Z"), which sorts chronologically.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "ingest/iso8601.h"

namespace km::server {

std::string NowUtcIso8601();
// Microseconds since the Unix epoch as "YYYY-MM-DDTHH:MM:SS.ffffffZ" (ingest/iso8601.h).
using ingest::UtcIso8601FromMicros;
// Normalises an ISO 8601 date or date-time (with Z, ±hh:mm or no zone = UTC) to UTC
// "YYYY-MM-DDTHH:MM:SS[.fff]Z". nullopt when the text is not such a time.
std::optional<std::string> NormaliseIso8601(const std::string& text);

}  // namespace km::server
