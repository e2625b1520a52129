// Parser of `kinemetric-dbb/1` DBB circular-test files (docs/formats.md §1.1). Strict: every error
// is a km::InvalidInput naming the file, the line and the field; nothing is guessed. Which samples
// are enough is the one coverage rule of analysis/dbb/coverage.h: every gap between neighbouring
// samples, the closing gap of a full turn included, at most 10°. Optional header `arc_deg`
// (180 … 360) declares a partial arc (or 360, a full turn); without it a trace that does not
// come back to its start is a partial arc of its own span, and the analysis says so in its
// result (evaluated_over, evaluated_arc_deg).
#pragma once

#include <string>
#include <string_view>

#include "analysis/dbb/dbb_types.h"

namespace km::ingest {

inline constexpr const char* kDbbFormat = "kinemetric-dbb/1";

struct DbbParseOptions {
  std::size_t max_bytes = 32u << 20;
  std::size_t max_samples = 2'000'000;
};

dbb::DbbTest ParseDbb(std::string_view bytes, const std::string& file,
                      const DbbParseOptions& options = {});

struct TextTable;

// The one validator of every DBB format: the header keys of §1.1 (identification, geometry,
// feed, time, arc, the bar's uncertainties) and the samples (angle_deg or t_s, and dr_um; order,
// magnitudes, coverage), each error a km::InvalidInput naming the file, the line and the field.
// `table` is what a DBB reader built from its file, whatever the file's own syntax
// (kinemetric-dbb/1: ReadTextTable; dbb-csv: ingest/dbb_csv_parser.h); its format is not read.
dbb::DbbTest DbbFromTable(const TextTable& table);

// The columns a DBB reader keeps (the others are checked, not kept).
bool IsDbbColumn(std::string_view column);

}  // namespace km::ingest
