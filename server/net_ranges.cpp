#include "server/net_ranges.h"

#include <arpa/inet.h>

#include <charconv>
#include <cstring>

namespace km::server {

std::optional<IpAddress> ParseIpAddress(const std::string& text) {
  IpAddress a;
  const std::string t = text == "localhost" ? "127.0.0.1" : text;
  if (inet_pton(AF_INET, t.c_str(), a.bytes.data()) == 1) return a;
  a.v6 = true;
  if (inet_pton(AF_INET6, t.c_str(), a.bytes.data()) == 1) return a;
  return std::nullopt;
}

std::optional<Network> ParseNetwork(const std::string& text) {
  const auto slash = text.find('/');
  const auto addr = ParseIpAddress(text.substr(0, slash));
  if (!addr || text.substr(0, slash) == "localhost") return std::nullopt;
  const int bits = addr->v6 ? 128 : 32;
  int prefix = bits;
  if (slash != std::string::npos) {
    const std::string digits = text.substr(slash + 1);
    const char* end = digits.data() + digits.size();
    const auto [ptr, ec] = std::from_chars(digits.data(), end, prefix);
    if (digits.empty() || ec != std::errc() || ptr != end || prefix < 0 || prefix > bits) {
      return std::nullopt;
    }
  }
  return Network{*addr, prefix, text};
}

bool NetworkContains(const Network& net, const IpAddress& addr) {
  if (net.base.v6 != addr.v6) return false;
  const int whole = net.prefix / 8;
  if (std::memcmp(net.base.bytes.data(), addr.bytes.data(), static_cast<std::size_t>(whole)) != 0) {
    return false;
  }
  const int rest = net.prefix % 8;
  if (rest == 0) return true;
  const auto mask = static_cast<std::uint8_t>(0xFF << (8 - rest));
  return (net.base.bytes[whole] & mask) == (addr.bytes[whole] & mask);
}

}  // namespace km::server
