#include "api/http_framing.h"

#include <cctype>
#include <string_view>

namespace km::api {
namespace {

std::string LowerTrimmed(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// The codings of every Transfer-Encoding field, in order (a coding's parameters kept).
std::vector<std::string> Codings(const std::vector<std::pair<std::string, std::string>>& headers) {
  std::vector<std::string> out;
  for (const auto& [name, value] : headers) {
    if (name != "transfer-encoding") continue;
    std::string_view rest = value;
    while (true) {
      const auto comma = rest.find(',');
      out.push_back(LowerTrimmed(rest.substr(0, comma)));
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  return out;
}

std::size_t Count(const std::vector<std::pair<std::string, std::string>>& headers,
                  const std::string& name) {
  std::size_t n = 0;
  for (const auto& h : headers) n += h.first == name ? 1 : 0;
  return n;
}

std::optional<FramingRefusal> CheckTransferEncoding(const std::vector<std::string>& codings,
                                                    bool has_length, unsigned version) {
  if (codings.empty()) return std::nullopt;
  if (version < 11) return FramingRefusal{400, "Transfer-Encoding is not allowed in HTTP/1.0"};
  if (codings.back() != "chunked") {
    return FramingRefusal{400,
                          "the final transfer coding must be 'chunked' (RFC 9112 §6.3); the "
                          "length of this body cannot be known"};
  }
  if (codings.size() > 1) {
    return FramingRefusal{501, "this server decodes the transfer coding 'chunked' only, once"};
  }
  if (has_length) {
    return FramingRefusal{400, "a request may not carry both Transfer-Encoding and Content-Length"};
  }
  return std::nullopt;
}

}  // namespace

std::optional<FramingRefusal> CheckFraming(
    const std::vector<std::pair<std::string, std::string>>& headers, unsigned version) {
  const std::size_t lengths = Count(headers, "content-length");
  if (auto te = CheckTransferEncoding(Codings(headers), lengths > 0, version)) return te;
  if (lengths > 1) return FramingRefusal{400, "Content-Length is given more than once"};
  const std::size_t hosts = Count(headers, "host");
  if (hosts > 1) return FramingRefusal{400, "Host is given more than once"};
  if (hosts == 0 && version >= 11) {
    return FramingRefusal{400, "an HTTP/1.1 request must carry a Host header"};
  }
  if (Count(headers, "authorization") > 1) {
    return FramingRefusal{400, "Authorization is given more than once"};
  }
  return std::nullopt;
}

std::optional<std::string> BearerToken(const std::string& authorization) {
  constexpr std::string_view kScheme = "bearer";
  if (authorization.size() <= kScheme.size() + 1) return std::nullopt;
  for (std::size_t i = 0; i < kScheme.size(); ++i) {
    const auto c = static_cast<unsigned char>(authorization[i]);
    if (std::tolower(c) != kScheme[i]) return std::nullopt;
  }
  std::size_t at = kScheme.size();
  if (authorization[at] != ' ') return std::nullopt;
  while (at < authorization.size() && authorization[at] == ' ') ++at;
  if (at == authorization.size()) return std::nullopt;
  return authorization.substr(at);
}

}  // namespace km::api
