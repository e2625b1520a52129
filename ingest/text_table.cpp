// The parsed text table (ingest/text_format.h): row lines, columns and header look-ups with
// the checks every format shares (required keys, finite numbers, lists of a given length).
#include <algorithm>
#include <stdexcept>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/text_format.h"

#include <cctype>

namespace km::ingest {

void RowLines::push_back(std::size_t line) {
  if (size_ == 0 || line != last_ + 1) {
    runs_.push_back({static_cast<std::uint32_t>(size_), static_cast<std::uint32_t>(line)});
  }
  last_ = line;
  ++size_;
}

std::size_t RowLines::operator[](std::size_t row) const {
  // The last run starting at or before `row`.
  const auto it = std::upper_bound(runs_.begin(), runs_.end(), row,
                                   [](std::size_t r, const Run& run) { return r < run.first_row; });
  const Run& run = *(it - 1);
  return run.first_line + (row - run.first_row);
}

double RowRef::operator[](std::size_t column) const {
  return table_->values.at(column).at(row_);
}

const std::vector<double>& TextTable::Column(std::size_t column) const {
  const auto& v = values.at(column);
  if (v.size() != row_count) {
    throw std::out_of_range("column '" + columns.at(column) + "' was not kept");
  }
  return v;
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

std::string TextTable::RequireMachineId() const {
  std::string id = RequireString("machine_id");
  CheckMachineId(id, file, KeyLine("machine_id"));
  return id;
}

std::size_t TextTable::KeyLine(const std::string& key) const {
  const auto* v = Find(key);
  return v ? v->line : 0;
}

std::string TextTable::RequireOneOf(const std::string& key,
                                    const std::set<std::string>& allowed) const {
  std::string v = RequireString(key);
  for (char& c : v) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (!allowed.count(v)) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    throw InvalidInput(file, KeyLine(key), key, Quote(v) + " is not one of " + list);
  }
  return v;
}

double TextTable::RequireNumber(const std::string& key) const {
  const auto* v = Find(key);
  if (!v) throw InvalidInput(file, 0, key, "required header key is missing");
  const auto n = ParseNumber(v->value);
  if (!n) {
    throw InvalidInput(file, v->line, key, Quote(v->value) + " is not a finite decimal number");
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
        Quote(v->value, 60) + " is not a comma-separated list of finite decimal numbers");
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

std::size_t TextTable::RequireColumn(const std::string& name) const {
  const int idx = ColumnIndex(name);
  if (idx < 0) throw InvalidInput(file, columns_line, name, "required column is missing");
  return static_cast<std::size_t>(idx);
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
