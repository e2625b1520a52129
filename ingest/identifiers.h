// What a name read from a client may hold (docs/formats.md §1, "Names and header values").
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
