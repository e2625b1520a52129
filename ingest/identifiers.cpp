#include "ingest/identifiers.h"

#include <cstdint>
#include <cstdio>

#include "analysis/core/errors.h"
#include "ingest/utf8_text.h"

namespace km::ingest {
namespace {

const char* CodePointName(char32_t cp) {
  switch (cp) {
    case 0x0A:
      return "a line feed";
    case 0x0D:
      return "a carriage return";
    case 0x0B:
      return "a vertical tab";
    case 0x0C:
      return "a form feed";
    case 0x85:
      return "a next-line character";
    case 0x2028:
      return "a line separator";
    case 0x2029:
      return "a paragraph separator";
    default:
      break;
  }
  if (cp < 0x20 || (cp >= 0x7F && cp <= 0x9F)) return "a control character";
  return "an invisible formatting character";
}

}  // namespace

std::optional<std::string> ForbiddenCharacter(std::string_view text) {
  for (std::size_t i = 0; i < text.size();) {
    char32_t cp = 0;
    const std::size_t n = Utf8Decode(text, i, cp);
    if (n == 0) return "bytes that are not UTF-8 at byte " + std::to_string(i);
    if (IsInvisibleOrControl(cp)) {
      char code[16];
      std::snprintf(code, sizeof code, "U+%04X", static_cast<unsigned>(cp));
      return std::string(CodePointName(cp)) + " (" + code + ") at byte " + std::to_string(i);
    }
    i += n;
  }
  return std::nullopt;
}

std::optional<std::string> MachineIdProblem(std::string_view id) {
  if (id.empty()) return "is empty";
  if (id.size() > kMaxMachineIdBytes) {
    return "is longer than " + std::to_string(kMaxMachineIdBytes) + " bytes";
  }
  if (id == "." || id == "..") return "is not a machine name";
  if (auto bad = ForbiddenCharacter(id)) return "holds " + *bad;
  for (const char c : id) {
    if (c == '/' || c == '\\') {
      return std::string("holds a '") + c + "' (a machine id is one segment of a URL path)";
    }
    if (c == '\t') return "holds a tab";
  }
  return std::nullopt;
}

void CheckMachineId(std::string_view id, const std::string& file, std::size_t line,
                    const std::string& field) {
  if (const auto why = MachineIdProblem(id)) {
    throw InvalidInput(file, line, field, Quote(id) + " " + *why);
  }
}

void CheckHeaderText(std::string_view value, const std::string& file, std::size_t line,
                     const std::string& field) {
  if (const auto bad = ForbiddenCharacter(value)) {
    throw InvalidInput(file, line, field,
                       Quote(value) + " holds " + *bad +
                           "; names and header values may not hold line breaks, control or "
                           "invisible formatting characters");
  }
}

bool IsControllerSafe(std::string_view text) {
  if (text.empty() || text.size() > 64) return false;
  for (const char c : text) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-' || c == ':';
    if (!ok) return false;
  }
  return true;
}

}  // namespace km::ingest
