#include "ingest/json_text.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "analysis/core/errors.h"

namespace km::ingest {

namespace {

using nlohmann::json;

// At most `n` bytes of UTF-8 text, cut before a character rather than inside one (a key is
// echoed in messages that end up in JSON answers and in storage).
std::string Utf8Prefix(const std::string& s, std::size_t n) {
  if (s.size() <= n) return s;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  return s.substr(0, n);
}

// Builds the document like nlohmann's own DOM parser, one level per open array or object, and
// keeps the path to the value being read for the error messages.
class CheckedDomBuilder {
 public:
  CheckedDomBuilder(std::string_view text, const std::string& file, JsonTextLimits limits)
      : text_(text), file_(file), limits_(limits) {}

  json& root() { return root_; }

  bool null() { return Add(json(nullptr)); }
  bool boolean(bool v) { return Add(json(v)); }
  bool number_integer(json::number_integer_t v) { return Add(json(v)); }
  bool number_unsigned(json::number_unsigned_t v) { return Add(json(v)); }
  bool number_float(json::number_float_t v, const json::string_t& /*text*/) {
    if (!std::isfinite(v)) Fail(0, "a number that does not fit a double");
    return Add(json(v));
  }
  bool string(json::string_t& v) { return Add(json(std::move(v))); }
  bool binary(json::binary_t& v) { return Add(json::binary(std::move(v))); }

  bool start_object(std::size_t /*elements*/) { return Open(json::object()); }
  bool start_array(std::size_t /*elements*/) { return Open(json::array()); }
  bool end_object() { return Close(); }
  bool end_array() { return Close(); }

  bool key(json::string_t& k) {
    Level& level = levels_.back();
    if (level.value->contains(k)) {
      level.key = std::move(k);
      Fail(0, "key given more than once");
    }
    level.key = std::move(k);
    return true;
  }

  bool parse_error(std::size_t position, const std::string& /*last_token*/,
                   const nlohmann::detail::exception& e) {
    // 406: a number beyond the range of a double ("1e999"); the lexer reports it here.
    if (e.id == 406) Fail(position, "a number that does not fit a double");
    // A syntax error belongs to no field: the line (and nlohmann's column) say where.
    throw InvalidInput(file_, LineAt(position), "", std::string("not valid JSON: ") + e.what());
  }

 private:
  struct Level {
    json* value;
    std::string key;  // objects: the key being read
  };

  bool Add(json v) {
    if (levels_.empty()) {
      root_ = std::move(v);
      return true;
    }
    Level& level = levels_.back();
    if (level.value->is_array()) {
      level.value->push_back(std::move(v));
    } else {
      (*level.value)[level.key] = std::move(v);
    }
    return true;
  }

  bool Open(json container) {
    if (levels_.size() >= limits_.max_depth) {
      Fail(0,
           "arrays and objects nest deeper than " + std::to_string(limits_.max_depth) + " levels");
    }
    json* slot = nullptr;
    if (levels_.empty()) {
      root_ = std::move(container);
      slot = &root_;
    } else if (Level& level = levels_.back(); level.value->is_array()) {
      level.value->push_back(std::move(container));
      slot = &level.value->back();
    } else {
      slot = &((*level.value)[level.key] = std::move(container));
    }
    levels_.push_back(Level{slot, {}});
    return true;
  }

  bool Close() {
    levels_.pop_back();
    return true;
  }

  // The path to the value being read: `a.b[3].c`, shortened in the middle when long.
  std::string Path() const {
    std::vector<std::string> parts;
    for (std::size_t i = 0; i < levels_.size(); ++i) {
      const Level& level = levels_[i];
      if (level.value->is_array()) {
        // The innermost level is about to take a new element; the others hold an open one.
        const std::size_t n = level.value->size();
        parts.push_back("[" + std::to_string(i + 1 == levels_.size() ? n : n - 1) + "]");
      } else if (!level.key.empty()) {
        parts.push_back((parts.empty() ? "" : ".") + Utf8Prefix(level.key, 64));
      }
    }
    constexpr std::size_t kKeep = 6;
    std::string out;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (parts.size() > 2 * kKeep && i == kKeep) out += "…";
      if (parts.size() > 2 * kKeep && i >= kKeep && i < parts.size() - kKeep) continue;
      out += parts[i];
    }
    return out;
  }

  std::size_t LineAt(std::size_t position) const {
    const std::size_t end = std::min(position, text_.size());
    return 1 + static_cast<std::size_t>(std::count(text_.begin(), text_.begin() + end, '\n'));
  }

  [[noreturn]] void Fail(std::size_t position, const std::string& reason) const {
    throw InvalidInput(file_, position == 0 ? 0 : LineAt(position), Path(), reason);
  }

  std::string_view text_;
  const std::string& file_;
  JsonTextLimits limits_;
  json root_;
  std::vector<Level> levels_;
};

}  // namespace

json ParseJsonText(std::string_view text, const std::string& file, JsonTextLimits limits) {
  CheckedDomBuilder builder(text, file, limits);
  json::sax_parse(text.begin(), text.end(), &builder);
  return std::move(builder.root());
}

json ParseJsonTextOrDiscarded(std::string_view text) {
  try {
    return ParseJsonText(text, "");
  } catch (const InvalidInput&) {
    return json(json::value_t::discarded);
  }
}

}  // namespace km::ingest
