// The dashboard's files, served read-only from one folder.
#include <filesystem>
#include <fstream>
#include <sstream>

#include "api/http_session.h"

namespace km::api {
namespace {

constexpr std::uintmax_t kMaxStaticBytes = 16u << 20;

std::string ContentTypeFor(const std::filesystem::path& p) {
  const auto ext = p.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".png") return "image/png";
  if (ext == ".json") return "application/json";
  return "application/octet-stream";
}

// Whether `p` is below `base` (both canonical).
bool Inside(const std::filesystem::path& base, const std::filesystem::path& p) {
  auto b = base.begin();
  auto q = p.begin();
  for (; b != base.end(); ++b, ++q) {
    if (q == p.end() || *q != *b) return false;
  }
  return q != p.end();
}

}  // namespace

Response ServeStatic(const std::string& root, const std::string& path) {
  namespace fs = std::filesystem;
  const std::string rel = path == "/" ? "index.html" : path.substr(std::string("/static/").size());
  const auto missing = [&] { return Problem(404, "Not Found", "no such file: " + path); };
  // Only plain names below the root: no "..", no hidden files, no absolute paths.
  if (root.empty() || rel.empty() || rel.find("..") != std::string::npos || rel.front() == '/' ||
      rel.front() == '.' || rel.find("/.") != std::string::npos) {
    return missing();
  }
  // The file itself, symbolic links resolved, must lie inside the root: a link below the root
  // to a file elsewhere is not served.
  std::error_code ec;
  const fs::path base = fs::canonical(root, ec);
  if (ec) return missing();
  const fs::path p = fs::canonical(base / rel, ec);
  if (ec || !Inside(base, p)) return missing();
  if (!fs::is_regular_file(p, ec) || fs::file_size(p, ec) > kMaxStaticBytes || ec) return missing();
  std::ifstream in(p, std::ios::binary);
  if (!in) return missing();
  std::ostringstream ss;
  ss << in.rdbuf();
  Response r;
  r.content_type = ContentTypeFor(p);
  r.body = ss.str();
  r.headers["Cache-Control"] = "no-cache";
  return r;
}

}  // namespace km::api
