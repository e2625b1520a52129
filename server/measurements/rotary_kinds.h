// The `kinemetric-rotary/1` measurement kind of the service (docs/formats.md §1.10): an R-test of
// the rotary axes of a trunnion table, evaluated at upload (the eight ISO 230-1 location errors
// with σ, rank and condition and the errors the poses cannot separate; usecases/rotary/
// rotary_report.h) and stored as kind "rotary", test_id the file's test_id (its set-up), with
// the sphere's measured displacement at each pose as samples.
#pragma once

#include <string>
#include <string_view>

#include "server/measurements/ingested.h"

namespace km::server {

// The handler of the format (server/measurements/kinds.h BuiltinFormats).
Ingested IngestRotary(std::string_view bytes, const std::string& file,
                      const InstrumentHook& instruments);

}  // namespace km::server
