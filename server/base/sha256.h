#pragma once
#include <string>
#include <string_view>

namespace km::server {
// Lower-case hex SHA-256 of the bytes.
std::string Sha256Hex(std::string_view bytes);
// Lower-case hex HMAC-SHA256 (RFC 2104) of the bytes under the key.
std::string HmacSha256Hex(std::string_view key, std::string_view bytes);
// A new random token (hex, 256 bits) from the system's cryptographic generator.
std::string NewRandomToken();
}  // namespace km::server
