// Set-ups: what a plant compares over time. A machine is measured in several set-ups in one
// session (planes, radii, feeds and directions of a DBB test, the axes of a laser positioning
// test, each straightness, flatness, parallelism and tracker test); each is judged on its own
// newest test and compared with its own history. A set-up is named by the kind, the
// measurement's test_id and (DBB) its direction; for a positioning test the test_id is the axis.
//
// A scope narrows a rule (or a tolerance) to some set-ups: test_id (exact, or a pattern where
// `*` stands for any run of characters), direction (DBB: cw or ccw) and axis (positioning).
// Without a key the scope takes every set-up of its kind.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace km::server {

struct SetUpScope {
  std::optional<std::string> test_id;    // exact, or with '*'
  std::optional<std::string> direction;  // "cw" or "ccw" (DBB only)
  std::optional<std::string> axis;       // upper case (positioning only)
};

// Whether `text` matches `pattern`, where '*' matches any run of characters (also none) and
// every other character itself. Linear in practice (at most one backtrack point at a time).
bool GlobMatch(std::string_view pattern, std::string_view text);

// Whether a measurement of `kind` with this test_id and direction lies in the scope.
bool InScope(const SetUpScope& scope, const std::string& test_id, const std::string& direction);

// The scope keys of a rule or tolerance object (test_id, direction, axis), checked against its
// kind; km::InvalidInput naming the field "<where>.<key>" (e.g. "rules[2].direction").
SetUpScope ParseSetUpScope(const nlohmann::json& object, const std::string& kind,
                           const std::string& where);
// Adds the scope's keys to an object (none when the scope is open).
void AddScopeJson(const SetUpScope& scope, nlohmann::json& object);
// The scope in words: "test_id xy-r*, CW", "axis X", "" when open.
std::string ScopeText(const SetUpScope& scope);

// A set-up's readable name: "xy-r150 CW", "axis X" (positioning), "(no test_id)".
std::string SetUpName(const std::string& kind, const std::string& test_id,
                      const std::string& direction);

}  // namespace km::server
