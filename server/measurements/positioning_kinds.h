// The `kinemetric-positioning/1` measurement kind of the service (docs/formats.md §1.8): a laser
// positioning run along one axis, corrected (air, material) and evaluated at upload (ISO 230-2,
// VDI/DGQ 3441, compensation table; usecases/positioning_report.h) and stored as kind
// "positioning", test_id the axis, with the corrected readings as samples.
#pragma once

#include <string>
#include <string_view>

#include "server/measurements/ingested.h"

namespace km::server {

// The handler of the format (server/measurements/kinds.h BuiltinFormats).
Ingested IngestPositioning(std::string_view bytes, const std::string& file,
                           const InstrumentHook& instruments);

}  // namespace km::server
