// Strict UTF-8 and how file content is shown in messages: the lowest layer of the readers,
// shared by the text reader (ingest/text_format.h) and the name rules (ingest/identifiers.h).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace km::ingest {

// Strict UTF-8 (Unicode table 3-7: no overlong forms, no UTF-16 surrogates, nothing above
// U+10FFFF). On failure `bad_at` is the offset of the first byte of the bad sequence and
// `reason` says what is wrong with it.
bool ValidUtf8(std::string_view s, std::size_t& bad_at, std::string* reason = nullptr);

// The code point of the valid sequence at s[i] and its length in bytes; 0 (cp untouched) when
// the bytes there are not strict UTF-8.
std::size_t Utf8Decode(std::string_view s, std::size_t i, char32_t& cp);

// Characters that break a line or that a reader cannot see: C0 controls but tab, DEL, C1
// controls (U+0080…U+009F, NEL U+0085 among them), U+2028 / U+2029, the zero-width and
// direction marks U+200B…U+200F, the bidirectional embeddings, overrides and isolates
// U+202A…U+202E and U+2066…U+2069, and U+FEFF.
bool IsInvisibleOrControl(char32_t cp);

// "\xNN" for a byte.
std::string HexByte(unsigned char c);

// File content for an error message, between single quotes: at most `max_chars` characters
// (cut at a character boundary, "..." appended when cut); control characters and DEL are
// written as \xNN, other characters of IsInvisibleOrControl as \u{NNNN}, bytes that are not
// part of valid UTF-8 as \xNN, a backslash as \\. The result is valid UTF-8 and shows on one
// line whatever the input.
std::string Quote(std::string_view text, std::size_t max_chars = 40);

}  // namespace km::ingest
