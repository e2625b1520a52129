// Access control in the service: who a token is (Authenticate), tokens made, listed and revoked
// by an admin, and the audit log of state-changing requests. Tokens are 256-bit random secrets
// shown once; only their SHA-256 is stored and looked up (docs/formats.md, API section).
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "server/access/roles.h"
#include "server/storage/storage.h"

namespace km::server {

// The holder of a valid token.
struct Caller {
  TokenId token_id;
  std::string name;
  Role role = Role::kViewer;
  std::optional<std::int64_t> expires_unix;  // seconds since the epoch; none: never
};

// The caller of a token hash; km::Unauthorized when the hash is unknown, or the token was
// revoked or has expired (the message says which), or its stored role is not a role.
Caller Authenticate(AccessStore& storage, const std::string& token_sha256);

// When a token was last used is stored to within this many seconds: a token's first request
// seen by a recorder, then at most one write a minute per token, not one per request.
inline constexpr std::int64_t kTokenUseResolutionS = 60;

// Records the requests of accepted tokens (AccessStore::TouchToken, throttled as above), one
// recorder a server. A storage failure here is not the request's: it is dropped, and the next
// use after the resolution tries again.
class TokenUseRecorder {
 public:
  explicit TokenUseRecorder(AccessStore& store) : store_(store) {}
  void Note(TokenId token_id);

 private:
  AccessStore& store_;
  std::mutex mu_;
  std::unordered_map<TokenId, std::int64_t> stored_;  // token id → unix seconds written
};

// Counts the revocations made in this process: a cache of accepted tokens forgets them all
// when the count changes.
std::uint64_t TokenRevocations();

// Tokens and the audit log, for an admin (api/access.cpp).
class AccessService {
 public:
  explicit AccessService(AccessStore& store) : store_(store) {}

  // POST /api/v1/tokens: {"name", "role", "expires_in_s"?} → {"id", "token", "role", "name",
  // "created_at", "expires_at"}; the secret appears only in this answer. InvalidInput names the
  // bad field.
  nlohmann::json CreateToken(const nlohmann::json& request);
  // Every token: {"items": [{"id", "name", "role", "created_at", "expires_at", "revoked_at",
  // "last_used_at", "state": "active" | "expired" | "revoked"}]}; never a secret or a hash.
  nlohmann::json ListTokens();
  // Revokes a token at once (NotFound for an unknown id; Conflict for the last active admin
  // token, so that the service is never left without one): {"id", "revoked_at"}.
  nlohmann::json RevokeToken(TokenId id);

  // Appends one entry to the audit log (the storage's errors go to the caller).
  void RecordAudit(const AuditEntry& entry);
  // {"items": [{"id", "at", "token_id", "token_name", "role", "method", "path", "status",
  // "subject"}], "total", "limit", "offset"}, newest first.
  nlohmann::json AuditLog(std::int64_t limit, std::int64_t offset);

  // Is this hash a stored token?
  bool TokenKnown(const std::string& token_sha256);
  // On a database without tokens, stores the bootstrap token (when given) or a new random one,
  // which is returned (to be shown once); otherwise returns "".
  std::string EnsureAdminToken(const std::string& bootstrap);
  AccessStore& store() { return store_; }

 private:
  AccessStore& store_;
};

// The admin token of a database without tokens (AccessService::EnsureAdminToken).
std::string EnsureAdminToken(AccessStore& storage, const std::string& bootstrap);

// Seconds since the epoch as "YYYY-MM-DDTHH:MM:SSZ", and back (nullopt for other text).
std::string UtcIso8601FromSeconds(std::int64_t unix_seconds);
std::optional<std::int64_t> SecondsFromUtcIso8601(const std::string& text);

}  // namespace km::server
