#include "server/base/sha256.h"

#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include "analysis/core/errors.h"

namespace km::server {
namespace {
std::string Hex(const unsigned char* p, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    out[2 * i] = digits[p[i] >> 4];
    out[2 * i + 1] = digits[p[i] & 15];
  }
  return out;
}
}  // namespace

std::string Sha256Hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr) != 1) {
    throw Error("SHA-256 computation failed");
  }
  return Hex(md, len);
}

std::string HmacSha256Hex(std::string_view key, std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  if (key.size() > 1 << 20 || HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
                                   reinterpret_cast<const unsigned char*>(bytes.data()),
                                   bytes.size(), md, &len) == nullptr) {
    throw Error("HMAC-SHA256 computation failed");
  }
  return Hex(md, len);
}

std::string NewRandomToken() {
  unsigned char buf[32];
  if (RAND_bytes(buf, sizeof buf) != 1) throw Error("no random bytes for a token");
  return Hex(buf, sizeof buf);
}

}  // namespace km::server
