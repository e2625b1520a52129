// The common shape of every kinemetric measurement file (docs/formats.md §1): UTF-8 text, header
// lines `# key: value` (the first names the format), one CSV column-header row, then numeric
// data rows. This reader validates the shape strictly and remembers the line of everything,
// so each format parser can report errors naming file, line and field.
//
// Memory: the data are kept as one std::vector<double> per column (reserved once, never
// regrown), the line of each row as runs of consecutive lines; nothing is allocated per row or
// per cell. Columns a parser does not ask for are checked but not kept. What a file may hold is
// bounded by TextLimits, and a file beyond a limit is refused (km::TooLarge) at the first line
// that exceeds it, before the rest is read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "ingest/identifiers.h"

namespace km::ingest {

struct HeaderValue {
  std::string value;
  std::size_t line = 0;
};

// A `# key: value` line met after the column header (e.g. `# beam_break: 2, 17`).
struct Marker {
  std::string key;
  std::string value;
  std::size_t line = 0;
  std::size_t before_row = 0;  // index of the data row that follows the marker
};

// What one file may hold. Each is checked as the file is read; the first line beyond a limit is
// refused with km::TooLarge naming the file and that line.
struct TextLimits {
  std::size_t max_bytes = 64u << 20;    // the whole file
  std::size_t max_rows = 5'000'000;     // data rows
  std::size_t max_line_bytes = 4096;    // one line, without its line break
  std::size_t max_columns = 128;        // cells of the column-header row
  std::size_t max_cells = SIZE_MAX;     // data values in all: rows × columns
  std::size_t max_header_lines = 1000;  // '#' lines before the column-header row
  std::size_t max_markers = 100'000;    // '#' lines among the data rows
};

struct ReadOptions : TextLimits {
  std::set<std::string> repeatable_keys;  // header keys that may occur more than once
  // Columns whose values are kept (every cell of every column is checked all the same);
  // empty: all columns.
  std::function<bool(std::string_view name)> keep_column;
  // Columns whose cells are words, each read as the number it maps to (e.g. `direction`: "+" → 1,
  // "-" → −1); any other cell of such a column is refused naming the words allowed.
  std::map<std::string, std::map<std::string, double, std::less<>>> word_columns;
};

// The line of every data row, stored as runs of rows on consecutive lines: a file without
// blank or '#' lines among its data rows needs one run.
class RowLines {
 public:
  void push_back(std::size_t line);
  std::size_t operator[](std::size_t row) const;  // row < size()
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::size_t back() const { return last_; }
  std::size_t runs() const { return runs_.size(); }

 private:
  struct Run {
    std::uint32_t first_row = 0;
    std::uint32_t first_line = 0;
  };
  std::vector<Run> runs_;
  std::size_t size_ = 0;
  std::size_t last_ = 0;
};

struct TextTable;

// The values of one data row, read from the columns (only kept columns may be read).
class RowRef {
 public:
  RowRef(const TextTable& table, std::size_t row) : table_(&table), row_(row) {}
  double operator[](std::size_t column) const;

 private:
  const TextTable* table_;
  std::size_t row_;
};

struct TextTable {
  std::string file;  // name used in messages
  std::string format;
  std::size_t format_line = 0;
  std::vector<std::pair<std::string, HeaderValue>> header;  // in file order
  std::vector<std::string> columns;
  std::size_t columns_line = 0;
  // values[c][row]: the data by column; empty for a column that was not kept.
  std::vector<std::vector<double>> values;
  std::size_t row_count = 0;
  RowLines row_lines;
  std::vector<Marker> markers;

  std::size_t NumRows() const { return row_count; }
  RowRef Row(std::size_t row) const { return RowRef(*this, row); }
  // The values of a kept column (throws std::out_of_range for a column not kept).
  const std::vector<double>& Column(std::size_t column) const;

  bool Has(const std::string& key) const;
  // The single value of a key; nullptr when absent.
  const HeaderValue* Find(const std::string& key) const;
  std::vector<const HeaderValue*> FindAll(const std::string& key) const;

  // The line of a header key (0 when absent).
  std::size_t KeyLine(const std::string& key) const;
  // Typed accessors; they throw InvalidInput naming file, line and field.
  std::string RequireString(const std::string& key) const;
  // The `machine_id` key, refused unless it can name a machine (ingest/identifiers.h).
  std::string RequireMachineId() const;
  // A required value, lower-cased, that must be one of `allowed` (lower case).
  std::string RequireOneOf(const std::string& key, const std::set<std::string>& allowed) const;
  double RequireNumber(const std::string& key) const;
  std::optional<double> OptionalNumber(const std::string& key) const;
  std::vector<double> RequireNumbers(const std::string& key, std::size_t count) const;
  std::optional<std::vector<double>> OptionalNumbers(const std::string& key,
                                                     std::size_t count) const;
  // Index of a column by name, or -1.
  int ColumnIndex(const std::string& name) const;
  // Index of a column the format requires; InvalidInput naming the columns line if absent.
  std::size_t RequireColumn(const std::string& name) const;
  // All header keys as a map (last value wins; repeatable keys joined by "; ").
  std::map<std::string, std::string> Metadata() const;
};

// Reads the generic structure. Throws InvalidInput / TooLarge.
TextTable ReadTextTable(std::string_view bytes, const std::string& file,
                        const ReadOptions& options = {});

// Checks the limits alone, in one pass that parses no number and keeps nothing: how an upload
// is refused before any parsing. Throws TooLarge naming file and line.
void CheckTextLimits(std::string_view bytes, const std::string& file, const TextLimits& limits);

// ---- the pieces every text reader shares (ReadTextTable and the readers of formats without a
// `# format:` line, e.g. ingest/dbb_csv_parser.h) ----

// The whole file at most max_bytes (and under 4 GiB); TooLarge otherwise.
void CheckTextSize(std::string_view bytes, const std::string& file, std::size_t max_bytes);
// Strict UTF-8 without NUL bytes; InvalidInput naming line and byte column otherwise.
void CheckTextBytes(std::string_view bytes, const std::string& file);
// The names of a CSV column-header row: identifiers, none twice.
std::vector<std::string> ReadColumnNames(std::string_view line, const std::string& file,
                                         std::size_t line_no);

using WordMap = std::map<std::string, double, std::less<>>;

// What a reader keeps of each column (set by StartColumns).
struct TableColumns {
  std::vector<char> keep;
  std::vector<const WordMap*> words;  // nullptr: a numeric column
};

// Reads the column-header row into `t` (columns, columns_line, values reserved for data_rows).
void StartColumns(TextTable& t, std::string_view line, std::size_t line_no,
                  const ReadOptions& options, std::size_t data_rows, TableColumns& cols);
// Reads one data row into `t`: as many cells as columns, each a strict number (or a word of a
// word column); InvalidInput naming file, line and column otherwise.
void ReadDataRow(TextTable& t, std::string_view line, std::size_t line_no,
                 const TableColumns& cols);

// The format line only (`# format: NAME/VERSION`, NAME of letters, digits, '.', '_', '-',
// VERSION of digits), e.g. to dispatch on the kind of file. Throws InvalidInput when the first
// non-blank line is not such a line; the message never repeats more than a short, escaped
// excerpt of it.
std::string PeekFormat(std::string_view bytes, const std::string& file);

// ---- instrument keys (docs/formats.md "Instrument keys (every kind)") ----
//
// Every kind of file may name the instrument it was measured with and state standard
// uncertainties; ReadTextTable checks these header keys wherever they appear before the
// column-header row, so every parser refuses a bad one naming file, line and key:
//   u_*                     a number from 0 to kMaxStandardUncertainty (a standard
//                           uncertainty, k = 1)
//   instrument              free text, at most kMaxInstrumentTextBytes
//   instrument_serial       InstrumentSerialProblem: 1 to 64 characters A–Z a–z 0–9 '_' '.'
//                           '-' ':', starting with a letter or digit
//   instrument_calibrated   an ISO date YYYY-MM-DD (a real day, years 1900…9999)
//   instrument_certificate  free text, at most kMaxInstrumentTextBytes
// (free text, like every header value, holds no line break, control or invisible character).

inline constexpr std::size_t kMaxInstrumentSerialBytes = 64;
// The largest standard uncertainty a u_* key may state, in its own unit (1 m in µm, 100 % in
// ppm): a larger one is no measurement's.
inline constexpr double kMaxStandardUncertainty = 1e6;
inline constexpr std::size_t kMaxInstrumentTextBytes = 256;

// Why `serial` cannot name an instrument; nullopt when it can. A serial is copied into URLs
// (/api/v1/instruments/{serial}), CSV and controller files, JSON and HTML: only characters that
// mean nothing in any of them, never a leading '-' (a CSV formula) or a '.' ("." and "..").
std::optional<std::string> InstrumentSerialProblem(std::string_view serial);

// The day of an ISO date written exactly YYYY-MM-DD (a real day of a year 1900…9999), as days
// since 1970-01-01; nullopt otherwise.
std::optional<std::int64_t> IsoDateDays(std::string_view text);
// YYYY-MM-DD of a day since 1970-01-01.
std::string IsoDateFromDays(std::int64_t days);
// The civil date (proleptic Gregorian) of a day since 1970-01-01 (H. Hinnant's civil_from_days).
struct CivilDate {
  std::int64_t year;
  unsigned month, day;
};
CivilDate CivilFromDays(std::int64_t days);

// Throws InvalidInput(file, line, key) when `value` is not what the header key `key` must hold
// (the table above); any other key passes.
void CheckInstrumentHeader(const std::string& key, std::string_view value, const std::string& file,
                           std::size_t line);

// Strict decimal number: the whole text must be a finite number (no NaN / Inf, no junk).
std::optional<double> ParseNumber(std::string_view text);
// Comma-separated list of strict numbers; nullopt if any element is bad.
std::optional<std::vector<double>> ParseNumberList(std::string_view text);

std::string_view Trim(std::string_view s);

}  // namespace km::ingest
