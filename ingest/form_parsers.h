// Parsers of the form-measurement files (docs/formats.md §1.3-1.5), built on the generic reader of
// ingest/text_format.h:
//   `# format: kinemetric-straightness/1`  columns position_mm,deviation_um
//   `# format: kinemetric-flatness/1`      columns x_mm,y_mm,z_um
//   `# format: kinemetric-parallelism/1`   columns position_mm,deviation_um
// Validation is strict: the exact format line, every required header key present and
// non-empty (duplicated keys are refused by the reader), enumerated values checked, every cell a
// finite decimal number, profile positions strictly increasing, a minimum number of points,
// no `#` lines among the data. Every error is a km::InvalidInput naming file, line and field.
// Unknown header keys and extra columns are kept / ignored.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/form/profile.h"
#include "ingest/text_format.h"

namespace km::ingest {

inline constexpr std::string_view kStraightnessFormat = "kinemetric-straightness/1";
inline constexpr std::string_view kFlatnessFormat = "kinemetric-flatness/1";
inline constexpr std::string_view kParallelismFormat = "kinemetric-parallelism/1";

struct StraightnessFile {
  std::string file;  // name used in messages
  std::string machine_id;
  std::string axis;               // travel axis, upper case (X, Y, Z, U, V, W)
  std::string error_direction;    // upper case, differs from axis
  std::string sensor;             // capacitance | laser | indicator
  std::string reference;          // artefact, e.g. optical_flat, straightedge
  std::string reversal;           // "a", "b" or "" (not part of a reversal pair)
  std::string pair_id;            // non-empty exactly when reversal is
  std::size_t reversal_line = 0;  // line of the `reversal` header key (0 when absent)
  // How set-up b of the pair was made (analysis/form/straightness.h): "artefact" (artefact
  // turned over, sensor stays; the default when the key is absent) or "artefact_and_sensor"
  // (the sensor moved to the other side as well); "" when not part of a reversal pair. Both
  // files of a pair must agree (checked where the pair is formed, server/form_report).
  std::string reversal_setup;
  std::size_t reversal_setup_line = 0;          // line of the `reversal_setup` key (0 when absent)
  std::map<std::string, std::string> metadata;  // every header key
  form::Profile profile;
  RowLines row_lines;  // file line of each point
};

struct FlatnessFile {
  std::string file;
  std::string machine_id;
  std::string datum;  // optional, "" when absent
  std::map<std::string, std::string> metadata;
  form::Grid grid;
  RowLines row_lines;
};

struct ParallelismFile {
  std::string file;
  std::string machine_id;
  std::string axis;   // upper case
  std::string datum;  // e.g. t_slot, table
  std::map<std::string, std::string> metadata;
  form::Profile profile;
  RowLines row_lines;
};

// Minimum numbers of data rows.
inline constexpr std::size_t kMinStraightnessPoints = 3;
inline constexpr std::size_t kMinFlatnessPoints = 3;  // and not all on one line
inline constexpr std::size_t kMinParallelismPoints = 2;

// What one form file may hold at most (ingest/text_format.h): 1 000 000 points, lines of
// 4 KiB, 32 columns. The server refuses larger uploads with its own, lower or equal, limits
// (ServiceOptions::upload_limits) before parsing.
TextLimits DefaultFormLimits();

// Each throws km::InvalidInput (or km::TooLarge) naming file, line and field. Parsing keeps
// the needed columns only: about 8 bytes a value, nothing per row.
StraightnessFile ParseStraightnessFile(std::string_view bytes, const std::string& file,
                                       const TextLimits& limits = DefaultFormLimits());
FlatnessFile ParseFlatnessFile(std::string_view bytes, const std::string& file,
                               const TextLimits& limits = DefaultFormLimits());
ParallelismFile ParseParallelismFile(std::string_view bytes, const std::string& file,
                                     const TextLimits& limits = DefaultFormLimits());

}  // namespace km::ingest
