#include "ingest/dbb_csv_parser.h"

#include <algorithm>
#include <set>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/text_lines.h"

namespace km::ingest {
namespace {

constexpr std::string_view kBom = "\xEF\xBB\xBF";
constexpr std::string_view kFirstKey = "machine_id,";

std::string_view FirstCell(std::string_view line) {
  return Trim(line.substr(0, line.find(',')));
}

// The column-header row starts with a DBB column; a header key never is one.
bool IsColumnHeader(std::string_view line) {
  const auto first = FirstCell(line);
  return first == "angle_deg" || first == "t_s" || first == "dr_um";
}

// A data row starts with a number; a header key never does.
bool IsDataRow(std::string_view line) {
  const char c = line.front();
  return (c >= '0' && c <= '9') || c == '+' || c == '-' || c == '.';
}

bool IsKey(std::string_view key) {
  if (key.empty() || !((key.front() >= 'a' && key.front() <= 'z') ||
                       (key.front() >= 'A' && key.front() <= 'Z') || key.front() == '_')) {
    return false;
  }
  for (const char c : key) {
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '-' || c == '.')) {
      return false;
    }
  }
  return true;
}

// The value of a `key,value` line: the rest of the line after the first comma, trimmed; a value
// a spreadsheet quoted (it holds a comma: `centre_mm,"0,0,0"`) loses its quotes, `""` is one '"'.
std::string CellValue(std::string_view rest, const std::string& file, std::size_t line,
                      const std::string& key) {
  rest = Trim(rest);
  if (rest.empty() || rest.front() != '"') return std::string(rest);
  if (rest.size() < 2 || rest.back() != '"') {
    throw InvalidInput(file, line, key, "the quoted value has no closing '\"'");
  }
  std::string value;
  const auto inner = rest.substr(1, rest.size() - 2);
  for (std::size_t i = 0; i < inner.size(); ++i) {
    if (inner[i] == '"') {
      if (i + 1 >= inner.size() || inner[i + 1] != '"') {
        throw InvalidInput(file, line, key, "a '\"' inside a quoted value is written '\"\"'");
      }
      ++i;
    }
    value += inner[i];
  }
  return value;
}

void RefuseHashLine(std::string_view line, const std::string& file, std::size_t line_no) {
  if (line.front() == '#') {
    throw InvalidInput(file, line_no, "",
                       "a dbb-csv file has no '#' lines (a file with '# format: …' lines is "
                       "kinemetric-dbb/1)");
  }
}

// One `key,value` line into the table's header, checked like a `# key: value` line.
void ReadKeyLine(TextTable& t, std::string_view line, std::size_t line_no,
                 std::set<std::string>& seen) {
  const auto comma = line.find(',');
  const std::string key(FirstCell(line));
  if (!IsKey(key)) {
    throw InvalidInput(t.file, line_no, "",
                       "expected a 'key,value' line or the column-header row (angle_deg,dr_um "
                       "or t_s,dr_um), found " +
                           Quote(line, 60));
  }
  if (comma == std::string_view::npos) {
    throw InvalidInput(t.file, line_no, key, "a header line is 'key,value'; the value is missing");
  }
  std::string value = CellValue(line.substr(comma + 1), t.file, line_no, key);
  CheckHeaderText(value, t.file, line_no, key);
  CheckInstrumentHeader(key, value, t.file, line_no);
  if (!seen.insert(key).second) {
    throw InvalidInput(
        t.file, line_no, key,
        "duplicated header key (first given on line " + std::to_string(t.KeyLine(key)) + ")");
  }
  t.header.push_back({key, HeaderValue{std::move(value), line_no}});
}

// Refuses a data row met before the column-header row, naming the line that should have been it.
[[noreturn]] void NoColumnHeader(const TextTable& t, std::size_t line_no) {
  const std::size_t at = t.header.empty() ? line_no : t.header.back().second.line;
  throw InvalidInput(
      t.file, at, "angle_deg",
      "expected the column-header row (angle_deg,dr_um or t_s,dr_um) before the "
      "data rows" +
          std::string(t.header.empty() ? ""
                                       : ", found the line '" + t.header.back().first + ",…'"));
}

std::size_t ScanDbbCsv(std::string_view bytes, const std::string& file, const TextLimits& limits) {
  CheckTextSize(bytes, file, limits.max_bytes);
  LineCursor cur(bytes, limits.max_line_bytes);
  std::size_t header_lines = 0, columns = 0, rows = 0;
  while (!cur.Done()) {
    const auto line = Trim(cur.Next(file));
    if (line.empty()) continue;
    if (columns == 0 && !IsColumnHeader(line)) {
      if (++header_lines > limits.max_header_lines) {
        throw TooLarge(file, cur.line(), "",
                       "more than " + std::to_string(limits.max_header_lines) +
                           " header lines before the column-header row");
      }
    } else if (columns == 0) {
      columns = 1 + static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
      if (columns > limits.max_columns) {
        throw TooLarge(file, cur.line(), "",
                       "the column-header row has " + std::to_string(columns) +
                           " columns; the limit is " + std::to_string(limits.max_columns));
      }
    } else if (++rows > limits.max_rows) {
      throw TooLarge(file, cur.line(), "",
                     "more than " + std::to_string(limits.max_rows) +
                         " data rows (the limit for this kind of file)");
    } else if (rows > limits.max_cells / columns) {
      throw TooLarge(file, cur.line(), "",
                     "more than " + std::to_string(limits.max_cells) +
                         " data values (rows × columns; the limit for this kind of file)");
    }
  }
  return rows;
}

}  // namespace

bool IsDbbCsv(std::string_view bytes) {
  if (bytes.substr(0, kBom.size()) == kBom) bytes.remove_prefix(kBom.size());
  const auto start = bytes.find_first_not_of(" \t\r\n\f\v");
  return start != std::string_view::npos && bytes.substr(start, kFirstKey.size()) == kFirstKey;
}

void CheckDbbCsvLimits(std::string_view bytes, const std::string& file, const TextLimits& limits) {
  ScanDbbCsv(bytes, file, limits);
}

TextTable ReadDbbCsvTable(std::string_view bytes, const std::string& file,
                          const TextLimits& limits) {
  const std::size_t data_rows = ScanDbbCsv(bytes, file, limits);
  CheckTextBytes(bytes, file);
  TextTable t;
  t.file = file;
  t.format = kDbbCsvFormat;
  ReadOptions options;
  options.keep_column = IsDbbColumn;
  TableColumns cols;
  std::set<std::string> seen;
  LineCursor cur(bytes, limits.max_line_bytes);
  while (!cur.Done()) {
    const auto line = Trim(cur.Next(file));
    const std::size_t line_no = cur.line();
    if (line.empty()) continue;
    RefuseHashLine(line, file, line_no);
    if (t.format_line == 0) {
      if (line.substr(0, kFirstKey.size()) != kFirstKey) {
        throw InvalidInput(file, line_no, "machine_id",
                           "a dbb-csv file starts with its 'machine_id,…' line");
      }
      t.format_line = line_no;  // the line that makes it a dbb-csv file
    }
    if (!t.columns.empty()) {
      ReadDataRow(t, line, line_no, cols);
    } else if (IsColumnHeader(line)) {
      StartColumns(t, line, line_no, options, data_rows, cols);
    } else if (IsDataRow(line)) {
      NoColumnHeader(t, line_no);
    } else {
      ReadKeyLine(t, line, line_no, seen);
    }
  }
  if (t.format_line == 0) throw InvalidInput(file, 0, "machine_id", "the file is empty");
  if (t.columns.empty()) {
    throw InvalidInput(file, cur.line(), "angle_deg",
                       "no column-header row (angle_deg,dr_um or t_s,dr_um)");
  }
  return t;
}

dbb::DbbTest ParseDbbCsv(std::string_view bytes, const std::string& file,
                         const DbbParseOptions& options) {
  TextLimits limits;
  limits.max_bytes = options.max_bytes;
  limits.max_rows = options.max_samples;
  return DbbFromTable(ReadDbbCsvTable(bytes, file, limits));
}

}  // namespace km::ingest
