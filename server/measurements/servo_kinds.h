// The `kinemetric-servo/1` measurement kind of the service (docs/formats.md §1.7): an upload is
// parsed, summarised (usecases/servo_report.h ServoSummaryJson) and stored as kind "servo" with
// its samples; the analyses that need the machine model or several files run from the CLI and
// the servo routes.
#pragma once

#include <string>
#include <string_view>

#include "server/measurements/ingested.h"

namespace km::server {

// The handler of the format (server/measurements/kinds.h BuiltinFormats).
Ingested IngestServo(std::string_view bytes, const std::string& file,
                     const InstrumentHook& instruments);

}  // namespace km::server
