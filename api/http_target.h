// The request target ("/path?key=value&…") taken apart: percent-decoding of the path and of
// query keys and values ('+' is a space in the query). Refused (returns the reason): a target
// not starting with '/', a bad %-escape, a NUL or other control character after decoding, and
// text that is not valid UTF-8 — so nothing a client sends can reach a route, a file name or an
// error message in a form that cannot be shown.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace km::api {

struct Target {
  std::string path;
  std::multimap<std::string, std::string> query;
};

// Empty optional and `error` set when the target is refused.
std::optional<Target> ParseTarget(std::string_view target, std::string& error);

// Strict UTF-8: no overlong forms, no surrogates (U+D800…DFFF), nothing above U+10FFFF.
bool IsUtf8(std::string_view text);

}  // namespace km::api
