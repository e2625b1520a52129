#include "ingest/text_format.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/text_lines.h"

namespace km::ingest {

std::string_view Trim(std::string_view s) {
  const char* ws = " \t\r\n\f\v";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(ws);
  return s.substr(b, e - b + 1);
}

std::optional<double> ParseNumber(std::string_view text) {
  text = Trim(text);
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return std::nullopt;
  // Only plain decimal / scientific text: from_chars would also accept "nan", "inf", hex.
  for (char c : text) {
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == 'e' || c == 'E' || c == '+')) {
      return std::nullopt;
    }
  }
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(v)) {
    return std::nullopt;
  }
  return v;
}

std::optional<std::vector<double>> ParseNumberList(std::string_view text) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    const auto part =
        text.substr(start, comma == std::string_view::npos ? text.npos : comma - start);
    const auto v = ParseNumber(part);
    if (!v) return std::nullopt;
    out.push_back(*v);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::optional<std::string> InstrumentSerialProblem(std::string_view serial) {
  if (serial.empty()) return "is empty";
  if (serial.size() > kMaxInstrumentSerialBytes) {
    return "is longer than " + std::to_string(kMaxInstrumentSerialBytes) + " characters";
  }
  const auto alnum = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
  };
  if (!alnum(serial.front())) return "does not start with a letter or a digit";
  for (const char c : serial) {
    if (!(alnum(c) || c == '_' || c == '.' || c == '-' || c == ':')) {
      return "holds " + Quote(std::string_view(&c, 1)) +
             " (a serial is letters, digits, '_', '.', '-' and ':')";
    }
  }
  return std::nullopt;
}

namespace {

// Days since 1970-01-01 of a day of the proleptic Gregorian calendar (H. Hinnant's
// days_from_civil).
std::int64_t DaysFromCivil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m > 2 ? m - 3 : m + 9) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

bool IsDateDigit(char c) {
  return c >= '0' && c <= '9';
}

}  // namespace

std::optional<std::int64_t> IsoDateDays(std::string_view text) {
  if (text.size() != 10 || text[4] != '-' || text[7] != '-') return std::nullopt;
  constexpr std::size_t kDigitsAt[] = {0, 1, 2, 3, 5, 6, 8, 9};
  for (const std::size_t i : kDigitsAt) {
    if (!IsDateDigit(text[i])) return std::nullopt;
  }
  const auto num = [&](std::size_t at, std::size_t n) {
    int v = 0;
    for (std::size_t i = at; i < at + n; ++i) v = v * 10 + (text[i] - '0');
    return v;
  };
  const int y = num(0, 4), m = num(5, 2), d = num(8, 2);
  if (y < 1900 || m < 1 || m > 12 || d < 1) return std::nullopt;
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  if (d > kDays[m - 1] + (m == 2 && leap ? 1 : 0)) return std::nullopt;
  return DaysFromCivil(y, static_cast<unsigned>(m), static_cast<unsigned>(d));
}

CivilDate CivilFromDays(std::int64_t days) {
  const std::int64_t z = days + 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const auto doe = static_cast<unsigned>(z - era * 146097);
  const unsigned yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const unsigned doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const unsigned mp = (5 * doy + 2) / 153;
  const unsigned d = doy - (153 * mp + 2) / 5 + 1;
  const unsigned m = mp < 10 ? mp + 3 : mp - 9;
  return {static_cast<std::int64_t>(yoe) + era * 400 + (m <= 2 ? 1 : 0), m, d};
}

std::string IsoDateFromDays(std::int64_t days) {
  const CivilDate c = CivilFromDays(days);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%04lld-%02u-%02u", static_cast<long long>(c.year), c.month,
                c.day);
  return buf;
}

void CheckInstrumentHeader(const std::string& key, std::string_view value, const std::string& file,
                           std::size_t line) {
  if (key.rfind("u_", 0) == 0) {
    const auto v = ParseNumber(value);
    if (!v || *v < 0 || *v > kMaxStandardUncertainty) {
      throw InvalidInput(
          file, line, key,
          Quote(value) + " is not a standard uncertainty (a decimal number from 0 to 1e6)");
    }
  } else if (key == "instrument_serial") {
    if (const auto why = InstrumentSerialProblem(value)) {
      throw InvalidInput(file, line, key, Quote(value) + " " + *why);
    }
  } else if (key == "instrument_calibrated") {
    if (!IsoDateDays(value)) {
      throw InvalidInput(file, line, key,
                         Quote(value) + " is not a calendar date written YYYY-MM-DD");
    }
  } else if (key == "instrument" || key == "instrument_certificate") {
    if (value.size() > kMaxInstrumentTextBytes) {
      throw InvalidInput(file, line, key,
                         "is longer than " + std::to_string(kMaxInstrumentTextBytes) + " bytes");
    }
  }
}

namespace {

// 1-based line of byte `offset` and its 1-based byte column within that line.
std::pair<std::size_t, std::size_t> LineAndColumn(std::string_view bytes, std::size_t offset) {
  const auto head = bytes.substr(0, offset);
  const std::size_t line = 1 + static_cast<std::size_t>(std::count(head.begin(), head.end(), '\n'));
  const auto nl = head.rfind('\n');
  const std::size_t column = nl == std::string_view::npos ? offset + 1 : offset - nl;
  return {line, column};
}

// Splits `# key: value` (after the '#'); returns false when the line is not of that shape.
bool SplitHeader(std::string_view body, std::string& key, std::string& value) {
  const auto colon = body.find(':');
  if (colon == std::string_view::npos) return false;
  const auto k = Trim(body.substr(0, colon));
  if (k.empty()) return false;
  for (char c : k) {
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '-' || c == '.')) {
      return false;
    }
  }
  key.assign(k);
  value.assign(Trim(body.substr(colon + 1)));
  return true;
}

constexpr std::size_t kMaxFormatLength = 64;

// NAME/VERSION: NAME of letters, digits, '.', '_', '-'; VERSION of digits.
bool ValidFormatName(std::string_view v) {
  if (v.empty() || v.size() > kMaxFormatLength) return false;
  const auto slash = v.find('/');
  if (slash == std::string_view::npos || slash == 0 || slash + 1 == v.size()) return false;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const char c = v[i];
    const bool digit = c >= '0' && c <= '9';
    if (i > slash) {
      if (!digit) return false;
    } else if (i < slash) {
      if (!(digit || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '.' || c == '_' ||
            c == '-')) {
        return false;
      }
    }
  }
  return true;
}

// The value of a format line `# format: NAME/VERSION` (line already trimmed, non-empty).
// Throws InvalidInput quoting at most a short, escaped excerpt of the line.
std::string FormatFromLine(std::string_view line, const std::string& file, std::size_t line_no) {
  std::string key, value;
  if (line.front() != '#' || !SplitHeader(line.substr(1), key, value) || key != "format") {
    throw InvalidInput(file, line_no, "format",
                       "the first line must be '# format: NAME/VERSION', found " + Quote(line));
  }
  if (value.empty()) throw InvalidInput(file, line_no, "format", "empty format name");
  if (!ValidFormatName(value)) {
    throw InvalidInput(file, line_no, "format",
                       Quote(value) +
                           " is not a format name (NAME/VERSION: letters, digits, '.', '_', '-', "
                           "then '/' and a version number; at most " +
                           std::to_string(kMaxFormatLength) + " characters)");
  }
  return value;
}

bool IsBlankOrSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

// What a line is, from its first non-blank byte.
enum class LineKind { kBlank, kHash, kOther };

LineKind KindOf(std::string_view raw) {
  for (char c : raw) {
    if (IsBlankOrSpace(c)) continue;
    return c == '#' ? LineKind::kHash : LineKind::kOther;
  }
  return LineKind::kBlank;
}

struct TextScan {
  std::size_t data_rows = 0;
};

// One pass over the lines checking every limit; parses nothing, keeps nothing.
TextScan ScanText(std::string_view bytes, const std::string& file, const TextLimits& limits) {
  CheckTextSize(bytes, file, limits.max_bytes);
  TextScan scan;
  LineCursor cur(bytes, limits.max_line_bytes);
  std::size_t header_lines = 0, markers = 0, columns = 0;
  bool have_columns = false;
  while (!cur.Done()) {
    const auto raw = cur.Next(file);
    switch (KindOf(raw)) {
      case LineKind::kBlank:
        break;
      case LineKind::kHash:
        if (!have_columns) {
          if (++header_lines > limits.max_header_lines) {
            throw TooLarge(file, cur.line(), "",
                           "more than " + std::to_string(limits.max_header_lines) +
                               " '#' lines before the column-header row");
          }
        } else if (++markers > limits.max_markers) {
          throw TooLarge(
              file, cur.line(), "",
              "more than " + std::to_string(limits.max_markers) + " '#' lines among the data rows");
        }
        break;
      case LineKind::kOther:
        if (!have_columns) {
          have_columns = true;
          columns = 1 + static_cast<std::size_t>(std::count(raw.begin(), raw.end(), ','));
          if (columns > limits.max_columns) {
            throw TooLarge(file, cur.line(), "",
                           "the column-header row has " + std::to_string(columns) +
                               " columns; the limit is " + std::to_string(limits.max_columns));
          }
          break;
        }
        if (++scan.data_rows > limits.max_rows) {
          throw TooLarge(file, cur.line(), "",
                         "more than " + std::to_string(limits.max_rows) +
                             " data rows (the limit for this kind of file)");
        }
        if (scan.data_rows > limits.max_cells / columns) {
          throw TooLarge(file, cur.line(), "",
                         "more than " + std::to_string(limits.max_cells) +
                             " data values (rows × columns; the limit for this kind of file)");
        }
        break;
    }
  }
  return scan;
}

// The word map of each column (nullptr: a numeric column).
std::vector<const WordMap*> WordColumns(const ReadOptions& options,
                                        const std::vector<std::string>& columns) {
  std::vector<const WordMap*> words(columns.size(), nullptr);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const auto w = options.word_columns.find(columns[c]);
    if (w != options.word_columns.end()) words[c] = &w->second;
  }
  return words;
}

// The number a word cell maps to; refuses any other word naming the ones allowed.
double WordValue(const WordMap& words, std::string_view cell, const std::string& file,
                 std::size_t line, const std::string& column) {
  const auto it = words.find(Trim(cell));
  if (it != words.end()) return it->second;
  std::string allowed;
  for (const auto& [word, value] : words) allowed += (allowed.empty() ? "'" : ", '") + word + "'";
  throw InvalidInput(file, line, column, Quote(Trim(cell)) + " is not one of " + allowed);
}

}  // namespace

void CheckTextSize(std::string_view bytes, const std::string& file, std::size_t max_bytes) {
  if (bytes.size() > max_bytes) {
    throw TooLarge(file, 0, "",
                   "the file is " + std::to_string(bytes.size()) + " bytes; the limit is " +
                       std::to_string(max_bytes));
  }
  // Row and line numbers are kept in 32 bits (RowLines).
  if (bytes.size() >= UINT32_MAX) {
    throw TooLarge(file, 0, "", "the file is larger than 4 GiB");
  }
}

// Strict UTF-8 and no NUL byte; errors name line and byte column and show the bytes escaped.
void CheckTextBytes(std::string_view bytes, const std::string& file) {
  std::size_t bad_at = 0;
  std::string reason;
  if (!ValidUtf8(bytes, bad_at, &reason)) {
    const auto [line, column] = LineAndColumn(bytes, bad_at);
    std::string shown;
    for (std::size_t k = bad_at; k < bytes.size() && k < bad_at + 4; ++k) {
      shown += HexByte(static_cast<unsigned char>(bytes[k]));
    }
    throw InvalidInput(file, line, "",
                       "the file is not valid UTF-8 text: byte column " + std::to_string(column) +
                           " (bytes " + shown + ") is " + reason);
  }
  if (const void* nul = std::memchr(bytes.data(), '\0', bytes.size())) {
    const auto offset = static_cast<std::size_t>(static_cast<const char*>(nul) - bytes.data());
    const auto [line, column] = LineAndColumn(bytes, offset);
    throw InvalidInput(file, line, "",
                       "the file contains a NUL byte (byte column " + std::to_string(column) +
                           "); it is not a text file");
  }
}

std::string PeekFormat(std::string_view bytes, const std::string& file) {
  // The first line is read up to the default line limit; it is checked before anything uses it.
  LineCursor cur(bytes, TextLimits{}.max_line_bytes);
  while (!cur.Done()) {
    std::string_view raw;
    try {
      raw = cur.Next(file);
    } catch (const TooLarge&) {
      throw InvalidInput(file, cur.line(), "format",
                         "the first line must be '# format: NAME/VERSION', found a line of more "
                         "than " +
                             std::to_string(TextLimits{}.max_line_bytes) + " bytes starting " +
                             Quote(bytes.substr(cur.pos(), 40)));
    }
    const auto line = Trim(raw);
    if (!line.empty()) return FormatFromLine(line, file, cur.line());
  }
  throw InvalidInput(file, 0, "format", "the file is empty");
}

void CheckTextLimits(std::string_view bytes, const std::string& file, const TextLimits& limits) {
  ScanText(bytes, file, limits);
}

std::vector<std::string> ReadColumnNames(std::string_view line, const std::string& file,
                                         std::size_t line_no) {
  std::vector<std::string> columns;
  std::set<std::string_view> names;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    const auto c =
        Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
    if (c.empty()) throw InvalidInput(file, line_no, "", "empty column name in header row");
    const bool ident = (std::isalpha(static_cast<unsigned char>(c.front())) || c.front() == '_') &&
                       std::all_of(c.begin(), c.end(), [](char ch) {
                         return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_';
                       });
    if (!ident) {
      throw InvalidInput(file, line_no, "",
                         "expected the CSV column-header row (names such as angle_deg,dr_um), "
                         "found " +
                             Quote(line, 60));
    }
    if (!names.insert(c).second) {
      throw InvalidInput(file, line_no, std::string(c), "duplicated column name");
    }
    columns.emplace_back(c);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return columns;
}

void StartColumns(TextTable& t, std::string_view line, std::size_t line_no,
                  const ReadOptions& options, std::size_t data_rows, TableColumns& cols) {
  t.columns = ReadColumnNames(line, t.file, line_no);
  t.columns_line = line_no;
  const std::size_t ncols = t.columns.size();
  cols.keep.assign(ncols, 1);
  cols.words = WordColumns(options, t.columns);
  t.values.resize(ncols);
  for (std::size_t c = 0; c < ncols; ++c) {
    if (options.keep_column && !options.keep_column(t.columns[c])) cols.keep[c] = 0;
    // The scan counted the data rows: each kept column is allocated once, to size.
    if (cols.keep[c]) t.values[c].reserve(data_rows);
  }
}

void ReadDataRow(TextTable& t, std::string_view line, std::size_t line_no,
                 const TableColumns& cols) {
  const std::size_t ncols = t.columns.size();
  const std::size_t found = 1 + static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
  if (found != ncols) {
    throw InvalidInput(
        t.file, line_no, "",
        "expected " + std::to_string(ncols) + " values, found " + std::to_string(found));
  }
  std::size_t start = 0;
  for (std::size_t c = 0; c < ncols; ++c) {
    const auto comma = c + 1 < ncols ? line.find(',', start) : std::string_view::npos;
    const auto cell =
        line.substr(start, comma == std::string_view::npos ? line.npos : comma - start);
    const auto v = cols.words[c] ? WordValue(*cols.words[c], cell, t.file, line_no, t.columns[c])
                                 : ParseNumber(cell);
    if (!v) {
      throw InvalidInput(t.file, line_no, t.columns[c],
                         Quote(Trim(cell)) + " is not a finite decimal number");
    }
    if (cols.keep[c]) t.values[c].push_back(*v);
    start = comma + 1;
  }
  t.row_lines.push_back(line_no);
  ++t.row_count;
}

TextTable ReadTextTable(std::string_view bytes, const std::string& file,
                        const ReadOptions& options) {
  // Limits first (one cheap pass), then the text itself, then the content.
  const TextScan scan = ScanText(bytes, file, options);
  CheckTextBytes(bytes, file);
  TextTable t;
  t.file = file;
  LineCursor cur(bytes, options.max_line_bytes);
  bool have_columns = false;
  std::set<std::string> seen;
  TableColumns cols;
  while (!cur.Done()) {
    const auto raw = cur.Next(file);
    const std::size_t line_no = cur.line();
    const auto line = Trim(raw);
    if (line.empty()) continue;
    if (t.format.empty()) {
      t.format = FormatFromLine(line, file, line_no);
      t.format_line = line_no;
      continue;
    }
    if (line.front() == '#') {
      std::string key, value;
      if (!SplitHeader(line.substr(1), key, value)) {
        throw InvalidInput(file, line_no, "", "a '#' line must have the form '# key: value'");
      }
      CheckHeaderText(value, file, line_no, key);
      if (!have_columns) CheckInstrumentHeader(key, value, file, line_no);
      if (have_columns) {
        t.markers.push_back({std::move(key), std::move(value), line_no, t.row_count});
        continue;
      }
      if (key == "format") {
        throw InvalidInput(file, line_no, "format", "the format line appears twice");
      }
      if (seen.count(key) && !options.repeatable_keys.count(key)) {
        const auto* first = t.Find(key);
        throw InvalidInput(file, line_no, key,
                           "duplicated header key (first given on line " +
                               std::to_string(first ? first->line : 0) + ")");
      }
      seen.insert(key);
      t.header.push_back({key, HeaderValue{std::move(value), line_no}});
      continue;
    }
    if (!have_columns) {
      StartColumns(t, line, line_no, options, scan.data_rows, cols);
      have_columns = true;
      continue;
    }
    ReadDataRow(t, line, line_no, cols);
  }
  if (t.format.empty()) throw InvalidInput(file, 0, "format", "the file is empty");
  if (!have_columns) throw InvalidInput(file, cur.line(), "", "no CSV column-header row");
  return t;
}

}  // namespace km::ingest
