#include "server/base/database_url.h"

#include <algorithm>

namespace km::server {

std::string MaskPassword(const std::string& url) {
  std::string out = url;
  const auto scheme = out.find("://");
  if (scheme != std::string::npos) {
    const auto start = scheme + 3;
    const auto end = std::min(out.find_first_of("/?#", start), out.size());
    const auto at = out.rfind('@', end == out.size() ? std::string::npos : end);
    if (at != std::string::npos && at >= start) {
      const auto colon = out.find(':', start);
      if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
    }
  }
  for (auto p = out.find("password="); p != std::string::npos; p = out.find("password=", p)) {
    p += 9;
    const auto end = std::min(out.find_first_of("& ", p), out.size());
    out.replace(p, end - p, "***");
  }
  return out;
}

}  // namespace km::server
