#include "ingest/text_format.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include "analysis/core/errors.h"

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

namespace {

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

std::vector<std::string_view> SplitCsv(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    out.push_back(
        Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

bool ValidUtf8(std::string_view s, std::size_t& bad_at) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t n = 0;
    if (c < 0x80) {
      n = 0;
    } else if ((c & 0xE0) == 0xC0 && c >= 0xC2) {
      n = 1;
    } else if ((c & 0xF0) == 0xE0) {
      n = 2;
    } else if ((c & 0xF8) == 0xF0 && c <= 0xF4) {
      n = 3;
    } else {
      bad_at = i;
      return false;
    }
    if (n > 0 && i + n >= s.size()) {
      bad_at = i;
      return false;
    }
    for (std::size_t k = 1; k <= n; ++k) {
      if ((static_cast<unsigned char>(s[i + k]) & 0xC0) != 0x80) {
        bad_at = i;
        return false;
      }
    }
    i += n + 1;
  }
  return true;
}

}  // namespace

std::string PeekFormat(std::string_view bytes, const std::string& file) {
  std::size_t pos = 0;
  std::size_t line_no = 0;
  if (bytes.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;  // UTF-8 byte-order mark
  while (pos <= bytes.size()) {
    const auto nl = bytes.find('\n', pos);
    const auto raw = bytes.substr(pos, nl == std::string_view::npos ? bytes.npos : nl - pos);
    ++line_no;
    const auto line = Trim(raw);
    if (!line.empty()) {
      std::string key, value;
      if (line.front() != '#' || !SplitHeader(line.substr(1), key, value) || key != "format") {
        throw InvalidInput(file, line_no, "format",
                           "the first line must be '# format: NAME/VERSION'");
      }
      if (value.empty()) throw InvalidInput(file, line_no, "format", "empty format name");
      return value;
    }
    if (nl == std::string_view::npos) break;
    pos = nl + 1;
  }
  throw InvalidInput(file, 0, "format", "the file is empty");
}

TextTable ReadTextTable(std::string_view bytes, const std::string& file,
                        const ReadOptions& options) {
  if (bytes.size() > options.max_bytes) {
    throw TooLarge(file, 0, "",
                   "file is " + std::to_string(bytes.size()) + " bytes; the limit is " +
                       std::to_string(options.max_bytes));
  }
  std::size_t bad_at = 0;
  if (!ValidUtf8(bytes, bad_at)) {
    std::size_t line = 1;
    for (std::size_t i = 0; i < bad_at; ++i) line += bytes[i] == '\n';
    throw InvalidInput(file, line, "", "the file is not valid UTF-8 text");
  }
  if (bytes.find('\0') != std::string_view::npos) {
    throw InvalidInput(file, 0, "", "the file contains a NUL byte; it is not a text file");
  }
  TextTable t;
  t.file = file;
  std::size_t pos = bytes.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;
  std::size_t line_no = 0;
  bool have_columns = false;
  std::set<std::string> seen;
  while (pos <= bytes.size()) {
    const auto nl = bytes.find('\n', pos);
    const auto raw = bytes.substr(pos, nl == std::string_view::npos ? bytes.npos : nl - pos);
    ++line_no;
    pos = (nl == std::string_view::npos) ? bytes.size() + 1 : nl + 1;
    const auto line = Trim(raw);
    if (line.empty()) continue;
    if (line.front() == '#') {
      std::string key, value;
      if (!SplitHeader(line.substr(1), key, value)) {
        throw InvalidInput(file, line_no, "", "a '#' line must have the form '# key: value'");
      }
      if (t.format.empty()) {
        if (key != "format") {
          throw InvalidInput(file, line_no, "format",
                             "the first line must be '# format: NAME/VERSION'");
        }
        if (value.empty()) throw InvalidInput(file, line_no, "format", "empty format name");
        t.format = value;
        t.format_line = line_no;
        continue;
      }
      if (have_columns) {
        t.markers.push_back({key, value, line_no, t.rows.size()});
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
      t.header.push_back({key, HeaderValue{value, line_no}});
      continue;
    }
    if (t.format.empty()) {
      throw InvalidInput(file, line_no, "format",
                         "the first line must be '# format: NAME/VERSION'");
    }
    const auto cells = SplitCsv(line);
    if (!have_columns) {
      std::set<std::string> names;
      for (const auto& c : cells) {
        if (c.empty()) throw InvalidInput(file, line_no, "", "empty column name in header row");
        const bool ident =
            (std::isalpha(static_cast<unsigned char>(c.front())) || c.front() == '_') &&
            std::all_of(c.begin(), c.end(), [](char ch) {
              return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_';
            });
        if (!ident) {
          throw InvalidInput(file, line_no, "",
                             "expected the CSV column-header row (names such as angle_deg,dr_um), "
                             "found '" +
                                 std::string(line.substr(0, 60)) + "'");
        }
        if (!names.insert(std::string(c)).second) {
          throw InvalidInput(file, line_no, std::string(c), "duplicated column name");
        }
        t.columns.emplace_back(c);
      }
      t.columns_line = line_no;
      have_columns = true;
      continue;
    }
    if (cells.size() != t.columns.size()) {
      throw InvalidInput(file, line_no, "",
                         "expected " + std::to_string(t.columns.size()) + " values, found " +
                             std::to_string(cells.size()));
    }
    if (t.rows.size() >= options.max_rows) {
      throw TooLarge(file, line_no, "",
                     "more than " + std::to_string(options.max_rows) + " data rows");
    }
    std::vector<double> row(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const auto v = ParseNumber(cells[i]);
      if (!v) {
        throw InvalidInput(
            file, line_no, t.columns[i],
            "'" + std::string(cells[i].substr(0, 40)) + "' is not a finite decimal number");
      }
      row[i] = *v;
    }
    t.rows.push_back(std::move(row));
    t.row_lines.push_back(line_no);
  }
  if (t.format.empty()) throw InvalidInput(file, 0, "format", "the file is empty");
  if (!have_columns) throw InvalidInput(file, line_no, "", "no CSV column-header row");
  return t;
}

bool TextTable::Has(const std::string& key) const {
  return Find(key) != nullptr;
}

const HeaderValue* TextTable::Find(const std::string& key) const {
  for (const auto& [k, v] : header) {
    if (k == key) return &v;
  }
  return nullptr;
}

std::vector<const HeaderValue*> TextTable::FindAll(const std::string& key) const {
  std::vector<const HeaderValue*> out;
  for (const auto& [k, v] : header) {
    if (k == key) out.push_back(&v);
  }
  return out;
}

std::string TextTable::RequireString(const std::string& key) const {
  const auto* v = Find(key);
  if (!v) throw InvalidInput(file, 0, key, "required header key is missing");
  if (v->value.empty()) throw InvalidInput(file, v->line, key, "value is empty");
  return v->value;
}

double TextTable::RequireNumber(const std::string& key) const {
  const auto* v = Find(key);
  if (!v) throw InvalidInput(file, 0, key, "required header key is missing");
  const auto n = ParseNumber(v->value);
  if (!n) {
    throw InvalidInput(file, v->line, key,
                       "'" + v->value.substr(0, 40) + "' is not a finite decimal number");
  }
  return *n;
}

std::optional<double> TextTable::OptionalNumber(const std::string& key) const {
  if (!Has(key)) return std::nullopt;
  return RequireNumber(key);
}

std::vector<double> TextTable::RequireNumbers(const std::string& key, std::size_t count) const {
  const auto* v = Find(key);
  if (!v) throw InvalidInput(file, 0, key, "required header key is missing");
  const auto n = ParseNumberList(v->value);
  if (!n) {
    throw InvalidInput(
        file, v->line, key,
        "'" + v->value.substr(0, 60) + "' is not a comma-separated list of finite decimal numbers");
  }
  if (n->size() != count) {
    throw InvalidInput(file, v->line, key,
                       "expected " + std::to_string(count) + " comma-separated numbers, found " +
                           std::to_string(n->size()));
  }
  return *n;
}

std::optional<std::vector<double>> TextTable::OptionalNumbers(const std::string& key,
                                                              std::size_t count) const {
  if (!Has(key)) return std::nullopt;
  return RequireNumbers(key, count);
}

int TextTable::ColumnIndex(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return static_cast<int>(i);
  }
  return -1;
}

std::map<std::string, std::string> TextTable::Metadata() const {
  std::map<std::string, std::string> out;
  for (const auto& [k, v] : header) {
    auto it = out.find(k);
    if (it == out.end()) {
      out.emplace(k, v.value);
    } else {
      it->second += "; " + v.value;
    }
  }
  return out;
}

}  // namespace km::ingest
