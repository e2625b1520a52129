#include "server/base/net_ranges.h"

#include <arpa/inet.h>

#include <charconv>
#include <cstring>

namespace km::server {
namespace {

const char* const kPrivateNetworks[] = {
    "0.0.0.0/8",     "10.0.0.0/8",     "100.64.0.0/10", "127.0.0.0/8", "169.254.0.0/16",
    "172.16.0.0/12", "192.168.0.0/16", "224.0.0.0/3",   "::/128",      "::1/128",
    "fc00::/7",      "fe80::/10",      "ff00::/8"};

// ::ffff:a.b.c.d as a.b.c.d; anything else unchanged.
IpAddress Unmapped(const IpAddress& addr) {
  static constexpr std::uint8_t kPrefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF};
  if (!addr.v6 || std::memcmp(addr.bytes.data(), kPrefix, sizeof kPrefix) != 0) return addr;
  IpAddress v4;
  std::memcpy(v4.bytes.data(), addr.bytes.data() + 12, 4);
  return v4;
}

}  // namespace

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

bool IsPrivateAddress(const IpAddress& addr) {
  static const std::vector<Network> networks = [] {
    std::vector<Network> out;
    for (const char* text : kPrivateNetworks) out.push_back(*ParseNetwork(text));
    return out;
  }();
  const IpAddress a = Unmapped(addr);
  for (const auto& net : networks) {
    if (NetworkContains(net, a)) return true;
  }
  return false;
}

}  // namespace km::server
