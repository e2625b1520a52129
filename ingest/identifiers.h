// Text read from a client: strict UTF-8, how it is shown in messages, and what a name or a
// header value may hold (docs/formats.md §1, "Names and header values"). The lowest layer of
// the readers (ingest/text_format.h builds on it).
//
// Every header value of a measurement file (and every machine id, test id and axis in it) is
// shown in reports, CSV files and compensation programs that a machine controller runs, where a
// line break starts a new program line. So no header value may hold a character that breaks a
// line or that a reader cannot see: C0 controls but tab, DEL, C1 controls (U+0080…U+009F, among
// them NEL U+0085), the line and paragraph separators U+2028 / U+2029, and the invisible format
// characters that change how text reads (zero-width U+200B…U+200F, bidirectional embeddings and
// isolates U+202A…U+202E and U+2066…U+2069, U+FEFF). A machine id also addresses URLs
// (/api/v1/machines/{machine_id}/…): it is 1 to 256 bytes, has no '/' or '\', no tab and is
// not "." or "..".
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace km::ingest {

// ---- strict UTF-8, and file content shown in messages ----

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

// ---- names and header values ----

constexpr std::size_t kMaxMachineIdBytes = 256;

// The first character of `text` that no name or header value may hold, described for a message
// ("a carriage return (U+000D) at byte 3"); nullopt when there is none. Bytes that are not
// UTF-8 count as such a character.
std::optional<std::string> ForbiddenCharacter(std::string_view text);

// Why `id` cannot be a machine id; nullopt when it can.
std::optional<std::string> MachineIdProblem(std::string_view id);

// Throws km::InvalidInput(file, line, field) when `id` cannot be a machine id.
void CheckMachineId(std::string_view id, const std::string& file, std::size_t line,
                    const std::string& field = "machine_id");

// Throws km::InvalidInput(file, line, field) when `value` holds a forbidden character.
void CheckHeaderText(std::string_view value, const std::string& file, std::size_t line,
                     const std::string& field);

// true when `text` is 1 to 64 bytes of A–Z, a–z, 0–9, '_', '.', '-' and ':' only: text that may
// be copied into a machine controller's file (a comment of a part program, say) as it is.
bool IsControllerSafe(std::string_view text);

}  // namespace km::ingest
