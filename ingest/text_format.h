// The common shape of every kinemetric measurement file (contract §1): UTF-8 text, header
// lines `# key: value` (the first names the format), one CSV column-header row, then numeric
// data rows. This reader validates the shape strictly and remembers the line of everything,
// so each format parser can report errors naming file, line and field.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

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

struct ReadOptions {
  std::size_t max_bytes = 64u << 20;      // larger input is refused (TooLarge)
  std::set<std::string> repeatable_keys;  // header keys that may occur more than once
  std::size_t max_rows = 5'000'000;
};

struct TextTable {
  std::string file;  // name used in messages
  std::string format;
  std::size_t format_line = 0;
  std::vector<std::pair<std::string, HeaderValue>> header;  // in file order
  std::vector<std::string> columns;
  std::size_t columns_line = 0;
  std::vector<std::vector<double>> rows;
  std::vector<std::size_t> row_lines;
  std::vector<Marker> markers;

  bool Has(const std::string& key) const;
  // The single value of a key; nullptr when absent.
  const HeaderValue* Find(const std::string& key) const;
  std::vector<const HeaderValue*> FindAll(const std::string& key) const;

  // Typed accessors; they throw InvalidInput naming file, line and field.
  std::string RequireString(const std::string& key) const;
  double RequireNumber(const std::string& key) const;
  std::optional<double> OptionalNumber(const std::string& key) const;
  std::vector<double> RequireNumbers(const std::string& key, std::size_t count) const;
  std::optional<std::vector<double>> OptionalNumbers(const std::string& key,
                                                     std::size_t count) const;
  // Index of a column by name, or -1.
  int ColumnIndex(const std::string& name) const;
  // All header keys as a map (last value wins; repeatable keys joined by "; ").
  std::map<std::string, std::string> Metadata() const;
};

// Reads the generic structure. Throws InvalidInput / TooLarge.
TextTable ReadTextTable(std::string_view bytes, const std::string& file,
                        const ReadOptions& options = {});

// The format line only (`# format: NAME/VERSION`), e.g. to dispatch on the kind of file.
// Throws InvalidInput when the first non-blank line is not a format line.
std::string PeekFormat(std::string_view bytes, const std::string& file);

// Strict decimal number: the whole text must be a finite number (no NaN / Inf, no junk).
std::optional<double> ParseNumber(std::string_view text);
// Comma-separated list of strict numbers; nullopt if any element is bad.
std::optional<std::vector<double>> ParseNumberList(std::string_view text);

std::string_view Trim(std::string_view s);

}  // namespace km::ingest
