// Words and numbers of the PDF reports (usecases/pdf_reports.h): fixed decimals, the label and
// unit of a result key, a table of a result object's figures. Internal to usecases/.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/pdf_report.h"
#include "usecases/report_inputs.h"

namespace km::usecases::report_text {

// v with `decimals` decimals; "—" for a missing, non-numeric or non-finite value.
std::string Fixed(const nlohmann::json& v, int decimals = 2);
std::string Fixed(double v, int decimals = 2);
// An uncertainty as the page prints it (web/static/format.js formatUncertainty): 2 significant
// digits, "0.00030", "0.016", "1.2", "15"; "—" for a missing or non-finite value.
std::string Sigma(const nlohmann::json& v);
// The name a reader knows a result's figure by, from its JSON key or path ("accuracy_up_um" →
// "unidirectional accuracy of positioning A↑", "vdi3441.P_um" → "position uncertainty P
// (VDI/DGQ 3441)", "circular_hysteresis_um" → "circular hysteresis H"); an unknown key with its
// underscores as spaces.
std::string FigureName(const std::string& key);
// Where a figure comes in the reports' order (ISO 230-2's A, A↑, A↓, E, …, then the others).
std::size_t FigureRank(const std::string& key);
// The name of an input uncertainty ("u_air_temperature_c" → "air temperature").
std::string InputName(const std::string& input);
// Free text from a result or the service as a report prints it: identifiers (snake_case words)
// as words or the figure's name, "um" as "µm", numbers with at most 3 decimals, no "-0.00".
std::string Readable(const std::string& text);
// The text with its first letter upper-case.
std::string Capitalised(std::string s);
// "circularity_um" → {"circularity", "µm"}; "angle_deg" → {"angle", "°"}.
struct KeyLabel {
  std::string label, unit;
};
KeyLabel LabelOf(const std::string& key);
// A JSON value as short text (a number with 3 decimals, a string as is, an array of numbers
// "(a, b, c)").
std::string Short(const nlohmann::json& v);
// The time as written by the API, or "—".
std::string When(const std::string& iso);
// Rows Figure | value | unit of every number (and array of up to 3 numbers) of an object, its
// nested objects' with "parent." before the key, skipping `skip`.
render::ReportTable FiguresTable(const nlohmann::json& object,
                                 const std::vector<std::string>& skip = {});
// The most rows a table of a report shows; a longer table is summarised (BoundedTable), so a
// report stays a few pages whatever the size of the data.
inline constexpr std::size_t kMaxTableRows = 200;
// The most rows of a table of sentences (audit rules and findings, discovery steps).
inline constexpr std::size_t kMaxTextTableRows = 100;
// The most notes (warnings) a report prints one by one.
inline constexpr std::size_t kMaxNotes = 20;
// The rows a table of n rows shows, ascending: all when n <= cap; else cap rows (a few fewer when
// they meet): the first, the last, the rows of `keep` (evenly chosen among them when they are
// more than the cap) and evenly spaced rows between.
std::vector<std::size_t> RowsShown(std::size_t n, std::size_t cap,
                                   const std::vector<std::size_t>& keep = {});
// How a long table is summarised: what its rows are, where the full table is, the rows shown
// whatever the spacing (e.g. the findings of the highest level) and what they are.
struct Summary {
  std::string noun;               // "targets"
  std::string where;              // "the JSON result of the measurement (GET …)"
  std::vector<std::size_t> keep;  // rows shown whatever the spacing
  std::string kept;               // what they are: "findings of the highest level"
  std::size_t cap = kMaxTableRows;
};
// A table summarised by evenly spaced rows alone.
Summary Evenly(std::string noun, std::string where, std::size_t cap = kMaxTableRows);
// The rows a table of n rows shows (RowsShown) and, when rows were left out, the sentence
// "N of M <noun> shown (evenly spaced from the first to the last, and every one of the <kept>);
// the full table is in <where>."
struct Shown {
  std::vector<std::size_t> rows;
  std::string sentence;  // "" when every row is shown
};
Shown Summarise(std::size_t n, const Summary& s);
// The table with the rows Summarise shows, followed by its sentence when rows were left out.
std::vector<render::ReportBlock> BoundedTable(render::ReportTable t, const Summary& s);
// Where the complete result of a measurement is: its JSON result on the API for a stored one,
// the file's JSON result for the command line.
std::string ResultAt(const ReportSource& s);
// Tables of the objects of `object` whose members are arrays of equal length (columns), e.g.
// the targets of a positioning test; each with its key as heading, at most kMaxTableRows rows
// (evenly spaced, with the first, the last and the largest and smallest value of each column)
// and then a sentence naming `where` the full table is.
std::vector<render::ReportBlock> ColumnTables(const nlohmann::json& object,
                                              const std::string& where);
// The table of the columns `columns` ({key, header}, in that order) of a column object (see
// ColumnTables), summarised the same way with `noun` ("targets") naming its rows.
std::vector<render::ReportBlock> ColumnTable(
    const nlohmann::json& object, const std::vector<std::pair<std::string, std::string>>& columns,
    const std::string& noun, const std::string& where);
// A laser positioning result (docs/formats.md §3) as a laser calibration report shows it: the
// chart of the mean deviations ±2s per direction, the ISO 230-2 figures in the standard's order
// with their letters, units and U, the VDI/DGQ 3441 figures, the conditions and corrections,
// the uncertainty of the figures and the targets (usecases/pdf_reports_positioning.cpp).
std::vector<render::ReportBlock> PositioningBlocks(const nlohmann::json& results,
                                                   const std::string& where);
// The report of a rotary-axis R-test (docs/formats.md §3.18): the location errors with σ and
// units, rank and condition, what the poses do not determine, the residual RMS and the
// displacement per pose (usecases/pdf_reports_positioning.cpp).
std::vector<render::ReportBlock> RotaryBlocks(const nlohmann::json& results,
                                              const std::string& where);
// The identification lines every measurement report starts with.
std::vector<std::pair<std::string, std::string>> Identification(const ReportSource& s);
// The audit section of a measurement report: the rules of its kind with their limits, and the
// newest verdict's judgement of the measurement's own set-up (its test_id and direction) under
// each: value, status and the measurement it judged.
std::vector<render::ReportBlock> AuditBlocks(const ReportAudit& audit, const ReportSource& source);
// Where a machine's audit rules and its verdicts are on the API.
std::string AuditAt(const std::string& machine_id);
std::string Footer(const std::string& what, const std::string& printed_at);
// The uncertainty of a result's figures (docs/formats.md §3.17) under the heading "Uncertainty"
// + `of`: the method, k and the inputs (stated, not stated), a table Figure | U | 95 % interval
// and the budget of the stated inputs; a sentence only when the file stated none. Nothing for a
// result without an `uncertainty` object.
std::vector<render::ReportBlock> UncertaintyBlocks(const nlohmann::json& uncertainty,
                                                   const std::string& of);

}  // namespace km::usecases::report_text
