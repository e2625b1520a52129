// Strict UTF-8 (RFC 3629): no overlong forms, no surrogates (U+D800…U+DFFF), nothing above
// U+10FFFF, no truncated sequences. Every string that goes into JSON (from storage or from a
// client) passes through SanitizeUtf8, so that writing JSON never fails on old or odd bytes.
#pragma once

#include <string>
#include <string_view>

namespace km::server {

// true when `text` is valid UTF-8 in the strict sense above.
bool IsValidUtf8(std::string_view text);

// `text` with every invalid sequence replaced by U+FFFD (one per maximal ill-formed subpart, as
// Unicode recommends); valid text comes back unchanged.
std::string SanitizeUtf8(std::string_view text);

}  // namespace km::server
