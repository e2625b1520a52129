#include "server/base/utf8.h"

#include <cstddef>
#include <cstdint>

#include "ingest/identifiers.h"

namespace km::server {
namespace {

// Length of the well-formed sequence at s[i], or 0 with `bad` = how many bytes form the
// maximal ill-formed subpart there (at least 1).
std::size_t Sequence(std::string_view s, std::size_t i, std::size_t& bad) {
  const auto b0 = static_cast<std::uint8_t>(s[i]);
  bad = 1;
  if (b0 < 0x80) return 1;
  std::size_t len = 0;
  std::uint8_t lo = 0x80, hi = 0xBF;  // range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    len = 2;
  } else if (b0 == 0xE0) {
    len = 3;
    lo = 0xA0;  // no overlong 3-byte forms
  } else if ((b0 >= 0xE1 && b0 <= 0xEC) || b0 == 0xEE || b0 == 0xEF) {
    len = 3;
  } else if (b0 == 0xED) {
    len = 3;
    hi = 0x9F;  // no surrogates
  } else if (b0 == 0xF0) {
    len = 4;
    lo = 0x90;  // no overlong 4-byte forms
  } else if (b0 >= 0xF1 && b0 <= 0xF3) {
    len = 4;
  } else if (b0 == 0xF4) {
    len = 4;
    hi = 0x8F;  // nothing above U+10FFFF
  } else {
    return 0;  // a continuation byte, C0, C1 or F5…FF
  }
  for (std::size_t k = 1; k < len; ++k) {
    if (i + k >= s.size()) return 0;
    const auto b = static_cast<std::uint8_t>(s[i + k]);
    const std::uint8_t l = k == 1 ? lo : 0x80, h = k == 1 ? hi : 0xBF;
    if (b < l || b > h) return 0;
    bad = k + 1;
  }
  return len;
}

}  // namespace

bool IsValidUtf8(std::string_view text) {
  std::size_t i = 0, bad = 0;
  while (i < text.size()) {
    const std::size_t n = Sequence(text, i, bad);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string SanitizeUtf8(std::string_view text) {
  if (IsValidUtf8(text)) return std::string(text);
  std::string out;
  out.reserve(text.size() + 8);
  std::size_t i = 0, bad = 0;
  while (i < text.size()) {
    const std::size_t n = Sequence(text, i, bad);
    if (n > 0) {
      out.append(text.substr(i, n));
      i += n;
    } else {
      out.append("\xEF\xBF\xBD");  // U+FFFD
      i += bad;
    }
  }
  return out;
}

bool HasControlOrLineBreak(std::string_view utf8) {
  // One rule with the header values of measurement files (ingest/identifiers.h), and tab too.
  return utf8.find('\t') != std::string_view::npos || ingest::ForbiddenCharacter(utf8).has_value();
}

}  // namespace km::server
