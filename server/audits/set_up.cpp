#include "server/audits/set_up.h"

#include <algorithm>
#include <cctype>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"

namespace km::server {

bool GlobMatch(std::string_view pattern, std::string_view text) {
  std::size_t p = 0, t = 0;
  std::size_t star = std::string_view::npos, resume = 0;
  while (t < text.size()) {
    if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      resume = t;
    } else if (p < pattern.size() && pattern[p] == text[t]) {
      ++p;
      ++t;
    } else if (star != std::string_view::npos) {
      p = star + 1;
      t = ++resume;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

bool InScope(const SetUpScope& scope, const std::string& test_id, const std::string& direction) {
  if (scope.test_id && !GlobMatch(*scope.test_id, test_id)) return false;
  if (scope.direction && *scope.direction != direction) return false;
  if (scope.axis && *scope.axis != test_id) return false;
  return true;
}

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

[[noreturn]] void Refuse(const std::string& where, const std::string& key, const std::string& why) {
  throw InvalidInput("", 0, where + "." + key, why);
}

std::optional<std::string> ScopeValue(const nlohmann::json& object, const char* key,
                                      const std::string& where) {
  if (!object.contains(key) || object[key].is_null()) return std::nullopt;
  if (!object[key].is_string()) Refuse(where, key, "must be a string");
  const std::string v = object[key].get<std::string>();
  if (v.empty() || v.size() > 256) Refuse(where, key, "must be 1 to 256 characters");
  if (const auto bad = ingest::ForbiddenCharacter(v)) {
    Refuse(where, key, "holds " + *bad + ", which no name may hold");
  }
  return v;
}

}  // namespace

SetUpScope ParseSetUpScope(const nlohmann::json& object, const std::string& kind,
                           const std::string& where) {
  SetUpScope s;
  s.test_id = ScopeValue(object, "test_id", where);
  if (auto d = ScopeValue(object, "direction", where)) {
    if (kind != "dbb") Refuse(where, "direction", "is only for kind dbb (cw or ccw)");
    *d = Lower(*d);
    if (*d != "cw" && *d != "ccw") Refuse(where, "direction", "must be \"cw\" or \"ccw\"");
    s.direction = d;
  }
  if (auto a = ScopeValue(object, "axis", where)) {
    if (kind != "positioning") Refuse(where, "axis", "is only for kind positioning");
    *a = Upper(*a);
    const bool ok =
        a->size() <= 8 && std::isalpha(static_cast<unsigned char>((*a)[0])) &&
        std::all_of(a->begin(), a->end(), [](unsigned char c) { return std::isalnum(c) != 0; });
    if (!ok) Refuse(where, "axis", "must be a letter, then letters or digits, at most 8 (X, Z2)");
    s.axis = a;
  }
  return s;
}

void AddScopeJson(const SetUpScope& scope, nlohmann::json& object) {
  if (scope.test_id) object["test_id"] = *scope.test_id;
  if (scope.direction) object["direction"] = *scope.direction;
  if (scope.axis) object["axis"] = *scope.axis;
}

std::string ScopeText(const SetUpScope& scope) {
  std::string out;
  const auto add = [&](const std::string& s) { out += (out.empty() ? "" : ", ") + s; };
  if (scope.axis) add("axis " + *scope.axis);
  if (scope.test_id) add("test_id " + *scope.test_id);
  if (scope.direction) add(Upper(*scope.direction));
  return out;
}

std::string SetUpName(const std::string& kind, const std::string& test_id,
                      const std::string& direction) {
  if (kind == "positioning" && !test_id.empty()) return "axis " + test_id;
  std::string name = test_id.empty() ? "(no test_id)" : test_id;
  return direction.empty() ? name : name + " " + Upper(direction);
}

}  // namespace km::server
