// Reader of `dbb-csv` DBB circular-test files (docs/formats.md §1.1a): the content of a
// kinemetric-dbb/1 file as a spreadsheet writes it. Comma-separated, no '#' line: `key,value`
// lines with the header keys of §1.1 (the `machine_id` line first), the column-header row
// (`angle_deg,dr_um` or `t_s,dr_um`, other columns checked but not kept), then the data rows.
//
// The file is read into the TextTable that ReadTextTable builds of a kinemetric-dbb/1 file, and
// checked by the same validator (ingest/dbb_parser.h DbbFromTable): the same keys, the same
// checks, the same DbbTest; every error a km::InvalidInput naming file, line and field; the same
// limits (DbbParseOptions; at upload the format's TextLimits, CheckDbbCsvLimits).
#pragma once

#include <string>
#include <string_view>

#include "analysis/dbb/dbb_types.h"
#include "ingest/dbb_parser.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr const char* kDbbCsvFormat = "dbb-csv";

// The format recognised from its bytes: after an optional UTF-8 byte-order mark and blank lines,
// the first line starts with `machine_id,`. No kinemetric file matches (their first line is
// `# format: …`).
bool IsDbbCsv(std::string_view bytes);

// The limits alone, in one pass that parses nothing (how an upload is refused before parsing):
// `key,value` lines count as header lines, the rows after the column header as data rows.
void CheckDbbCsvLimits(std::string_view bytes, const std::string& file, const TextLimits& limits);

// The table of a dbb-csv file (format "dbb-csv", header keys, columns, kept DBB columns).
TextTable ReadDbbCsvTable(std::string_view bytes, const std::string& file,
                          const TextLimits& limits);

dbb::DbbTest ParseDbbCsv(std::string_view bytes, const std::string& file,
                         const DbbParseOptions& options = {});

}  // namespace km::ingest
