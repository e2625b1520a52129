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

// true when `utf8` is not valid UTF-8 (above) or holds a control or line-breaking character:
// C0 (U+0000…U+001F, tab, CR and LF included), DEL (U+007F), C1 (U+0080…U+009F, NEL U+0085
// included), U+2028 LINE SEPARATOR, U+2029 PARAGRAPH SEPARATOR, or an invisible formatting
// character (zero-width, bidirectional: ingest::IsInvisibleOrControl). A name, id or other one-line
// text a client sends is refused when this is true, so it can never start a new line or carry
// an invisible control into a log, a file or another program.
bool HasControlOrLineBreak(std::string_view utf8);

}  // namespace km::server
