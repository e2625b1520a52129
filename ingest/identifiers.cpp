#include "ingest/identifiers.h"

#include <cstdint>
#include <cstdio>
#include <cstring>

#include "analysis/core/errors.h"

namespace km::ingest {

namespace {

// Length of the valid UTF-8 sequence starting at s[i] (Unicode table 3-7), or 0 with the
// reason when the bytes there are not one.
std::size_t Utf8SequenceLength(std::string_view s, std::size_t i, const char** reason) {
  const auto at = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = at(i);
  if (c < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // allowed range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c == 0xE0) {
    n = 3;
    lo = 0xA0;  // E0 80..9F would be an overlong form
  } else if (c == 0xED) {
    n = 3;
    hi = 0x9F;  // ED A0..BF would be a UTF-16 surrogate
  } else if (c >= 0xE1 && c <= 0xEF) {
    n = 3;
  } else if (c == 0xF0) {
    n = 4;
    lo = 0x90;  // F0 80..8F would be an overlong form
  } else if (c >= 0xF1 && c <= 0xF3) {
    n = 4;
  } else if (c == 0xF4) {
    n = 4;
    hi = 0x8F;  // F4 90.. would be above U+10FFFF
  } else {
    *reason = c < 0xC0   ? "a continuation byte without a lead byte"
              : c < 0xC2 ? "an overlong encoding"
                         : "a byte that never occurs in UTF-8";
    return 0;
  }
  if (i + n > s.size()) {
    *reason = "a sequence cut short by the end of the file";
    return 0;
  }
  const unsigned char second = at(i + 1);
  if (second < lo || second > hi) {
    if ((second & 0xC0) != 0x80) {
      *reason = "a sequence cut short";
    } else if (c == 0xE0 || c == 0xF0) {
      *reason = "an overlong encoding";
    } else if (c == 0xED) {
      *reason = "a UTF-16 surrogate";
    } else {
      *reason = "a code point above U+10FFFF";
    }
    return 0;
  }
  for (std::size_t k = 2; k < n; ++k) {
    if ((at(i + k) & 0xC0) != 0x80) {
      *reason = "a sequence cut short";
      return 0;
    }
  }
  return n;
}

}  // namespace

std::string HexByte(unsigned char c) {
  static const char* digits = "0123456789ABCDEF";
  return {'\\', 'x', digits[c >> 4], digits[c & 15]};
}

std::size_t Utf8Decode(std::string_view s, std::size_t i, char32_t& cp) {
  const char* why = "";
  const std::size_t n = i < s.size() ? Utf8SequenceLength(s, i, &why) : 0;
  if (n == 0) return 0;
  const auto lead = static_cast<unsigned char>(s[i]);
  if (n == 1) {
    cp = lead;
    return 1;
  }
  std::uint32_t v = lead & (0x7Fu >> n);
  for (std::size_t k = 1; k < n; ++k) v = (v << 6) | (static_cast<unsigned char>(s[i + k]) & 0x3Fu);
  cp = static_cast<char32_t>(v);
  return n;
}

bool IsInvisibleOrControl(char32_t cp) {
  if (cp == U'\t') return false;
  return cp < 0x20 || (cp >= 0x7F && cp <= 0x9F) || (cp >= 0x200B && cp <= 0x200F) ||
         cp == 0x2028 || cp == 0x2029 || (cp >= 0x202A && cp <= 0x202E) ||
         (cp >= 0x2066 && cp <= 0x2069) || cp == 0xFEFF;
}

bool ValidUtf8(std::string_view s, std::size_t& bad_at, std::string* reason) {
  std::size_t i = 0;
  const std::size_t n = s.size();
  while (i < n) {
    // ASCII runs eight bytes at a time.
    while (i + 8 <= n) {
      std::uint64_t w = 0;
      std::memcpy(&w, s.data() + i, 8);
      if (w & 0x8080808080808080ull) break;
      i += 8;
    }
    if (i >= n) break;
    if (static_cast<unsigned char>(s[i]) < 0x80) {
      ++i;
      continue;
    }
    const char* why = "";
    const std::size_t len = Utf8SequenceLength(s, i, &why);
    if (len == 0) {
      bad_at = i;
      if (reason) *reason = why;
      return false;
    }
    i += len;
  }
  return true;
}

std::string Quote(std::string_view text, std::size_t max_chars) {
  std::string out = "'";
  std::size_t i = 0, chars = 0;
  while (i < text.size()) {
    if (chars == max_chars) {
      out += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(text[i]);
    const char* why = "";
    const std::size_t len = Utf8SequenceLength(text, i, &why);
    if (len == 0) {
      out += HexByte(c);
      i += 1;
    } else if (len == 1) {
      if (c < 0x20 || c == 0x7F) {
        out += HexByte(c);
      } else if (c == '\\') {
        out += "\\\\";
      } else {
        out += static_cast<char>(c);
      }
      i += 1;
    } else {
      char32_t cp = 0;
      Utf8Decode(text, i, cp);
      if (IsInvisibleOrControl(cp)) {
        char buf[16];
        std::snprintf(buf, sizeof buf, "\\u{%X}", static_cast<unsigned>(cp));
        out += buf;
      } else {
        out.append(text.substr(i, len));
      }
      i += len;
    }
    ++chars;
  }
  out += "'";
  return out;
}

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
