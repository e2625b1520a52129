// The lines of a measurement text, one at a time, each checked against the line limit before it
// is used: shared by the readers of every text format (text_format.cpp, dbb_csv_parser.cpp).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>

#include "analysis/core/errors.h"

namespace km::ingest {

// Walks the lines of a text (after an optional byte-order mark). Each line is found without
// reading more than the line limit ahead, so a line beyond it is refused where it starts.
class LineCursor {
 public:
  LineCursor(std::string_view bytes, std::size_t max_line_bytes)
      : bytes_(bytes), max_line_(max_line_bytes) {
    if (bytes_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;  // UTF-8 byte-order mark
  }
  bool Done() const { return pos_ > bytes_.size(); }
  std::size_t line() const { return line_no_; }
  std::size_t pos() const { return pos_; }  // start of the next line

  // The next line without its line break. Throws TooLarge for a line beyond the limit.
  std::string_view Next(const std::string& file) {
    ++line_no_;
    const std::size_t remaining = bytes_.size() - pos_;
    // A line of max_line_ bytes may be followed by "\r\n".
    const std::size_t window = std::min(remaining, max_line_ + 2);
    const char* start = bytes_.data() + pos_;
    const void* nl = window ? std::memchr(start, '\n', window) : nullptr;
    std::size_t len = 0;
    std::size_t next = 0;
    if (nl) {
      len = static_cast<std::size_t>(static_cast<const char*>(nl) - start);
      next = pos_ + len + 1;
    } else {
      // The last line (no line break after it), or a line beyond the limit: no '\n' within
      // the window. Either way the length check below decides.
      len = remaining;
      next = bytes_.size() + 1;
    }
    std::string_view line(start, len);
    const std::size_t content = !line.empty() && line.back() == '\r' ? len - 1 : len;
    if (content > max_line_) {
      throw TooLarge(file, line_no_, "",
                     "the line is longer than " + std::to_string(max_line_) +
                         " bytes (the limit for one line)");
    }
    pos_ = next;
    return line;
  }

 private:
  std::string_view bytes_;
  std::size_t max_line_;
  std::size_t pos_ = 0;
  std::size_t line_no_ = 0;
};

}  // namespace km::ingest
