// The text of a PDF as poppler's pdftotext lays it out (-layout), for the tests that read a
// report back. The PDF is written to `path` first.
#pragma once

#include <array>
#include <cstdio>
#include <fstream>
#include <string>

namespace km::test {

inline std::string PdfToText(const std::string& pdf, const std::string& path) {
  std::ofstream(path, std::ios::binary) << pdf;
  std::string out;
  FILE* p = popen(("pdftotext -layout '" + path + "' - 2>&1").c_str(), "r");
  std::array<char, 4096> buf;
  std::size_t n;
  while (p && (n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  if (p) pclose(p);
  return out;
}

}  // namespace km::test
