// One cell of a CSV the program writes (RFC 4180, ',' between cells), safe to open in a
// spreadsheet. A number the program formats is written as it is; any text a client sent (a test
// id, a file name, a note, a machine id) goes through CsvCell:
//   - a text that is not entirely a decimal number (-3.25, +4, 1e-3, .5) and begins with '=',
//     '+', '-', '@', tab or CR gets a leading "'", so a spreadsheet shows it as text instead of
//     running it as a formula (OWASP, CSV injection): "=HYPERLINK(…)" → "'=HYPERLINK(…)",
//     "-3.25" stays "-3.25";
//   - a cell holding ',', ';', '"', CR or LF is put in double quotes, its quotes doubled (';' too,
//     for spreadsheets that split on it).
// The dashboard's CSV downloads follow the same rule (toCsv in web/static/dom.js).
#pragma once

#include <charconv>
#include <cmath>
#include <string>
#include <string_view>
#include <system_error>

namespace km::usecases {

// true when `text` is entirely a finite decimal number: an optional sign, digits with at most
// one '.', at least one digit, an optional exponent (e or E, optional sign, digits), and within
// the range of a double (1e999 is not).
inline bool IsCsvDecimalNumber(std::string_view text) {
  std::size_t i = 0;
  const auto digits = [&] {
    const std::size_t from = i;
    while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
    return i - from;
  };
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t mantissa = digits();
  if (i < text.size() && text[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return false;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  if (i != text.size()) return false;
  if (text.front() == '+') text.remove_prefix(1);  // from_chars takes '-' only
  double value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (end != text.data() + text.size()) return false;
  if (ec == std::errc::result_out_of_range) {  // 1e999 overflows; 1e-999 underflows, still finite
    return text.find("e-") != std::string_view::npos || text.find("E-") != std::string_view::npos;
  }
  return ec == std::errc() && std::isfinite(value);
}

// `text` as one CSV cell, by the rules above.
inline std::string CsvCell(std::string_view text) {
  std::string s;
  if (!text.empty() && !IsCsvDecimalNumber(text)) {
    const char c = text.front();
    if (c == '=' || c == '+' || c == '-' || c == '@' || c == '\t' || c == '\r') s = "'";
  }
  s.append(text);
  if (s.find_first_of(",;\"\r\n") == std::string::npos) return s;
  std::string quoted = "\"";
  for (const char c : s) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  quoted += '"';
  return quoted;
}

}  // namespace km::usecases
