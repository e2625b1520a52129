// Address ranges in CIDR notation ("127.0.0.0/8", "::1/128", "192.168.10.0/24"), for the hosts
// the server may be told to connect to (Modbus devices added through the API, audit webhooks).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace km::server {

struct IpAddress {
  bool v6 = false;
  std::array<std::uint8_t, 16> bytes{};  // IPv4 in the first 4
};

struct Network {
  IpAddress base;
  int prefix = 0;
  std::string text;  // as configured
};

// A numeric IPv4 or IPv6 address ("localhost" is 127.0.0.1); nullopt for anything else (host
// names are not resolved: what a name resolves to may change after the check).
std::optional<IpAddress> ParseIpAddress(const std::string& text);
// "ADDRESS/PREFIX" (a bare address is a network of one); nullopt when malformed.
std::optional<Network> ParseNetwork(const std::string& text);
bool NetworkContains(const Network& net, const IpAddress& addr);
// True for an address that is not a public unicast one: loopback (127.0.0.0/8, ::1),
// unspecified (0.0.0.0/8, ::), private (10.0.0.0/8, 172.16.0.0/12, 192.168.0.0/16,
// fc00::/7), shared (100.64.0.0/10), link-local (169.254.0.0/16, fe80::/10), multicast and
// reserved (224.0.0.0/3, ff00::/8); an IPv4 address mapped into IPv6 (::ffff:a.b.c.d) as its
// IPv4 address.
bool IsPrivateAddress(const IpAddress& addr);

}  // namespace km::server
