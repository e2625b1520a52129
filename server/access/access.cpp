#include "server/access/access.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <unordered_map>

#include "analysis/core/errors.h"
#include "server/base/errors.h"
#include "server/base/request_json.h"
#include "server/base/sha256.h"
#include "server/base/utf8.h"

namespace km::server {
namespace {

std::atomic<std::uint64_t> g_revocations{0};

constexpr std::int64_t kMaxExpiresInS = 10LL * 366 * 24 * 3600;  // ten years
constexpr std::size_t kMaxNameBytes = 128;

std::int64_t NowSeconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string TokenName(const nlohmann::json& request) {
  const std::string name = request::RequiredString(request, "name");
  if (name.size() > kMaxNameBytes) {
    throw InvalidInput(request::kFile, 0, "name",
                       "must be at most " + std::to_string(kMaxNameBytes) + " bytes");
  }
  if (!IsValidUtf8(name)) throw InvalidInput(request::kFile, 0, "name", "is not valid UTF-8");
  if (HasControlOrLineBreak(name)) {
    throw InvalidInput(request::kFile, 0, "name",
                       "holds a control, line-breaking or invisible formatting character (C0, "
                       "DEL, C1 such as U+0085, U+2028, U+2029, zero-width or bidirectional "
                       "controls)");
  }
  return name;
}

// "active", "expired" or "revoked" at `now`.
std::string TokenState(const TokenRecord& t, std::int64_t now) {
  if (t.revoked_at) return "revoked";
  if (t.expires_at) {
    const auto until = SecondsFromUtcIso8601(*t.expires_at);
    if (!until || now >= *until) return "expired";
  }
  return "active";
}

nlohmann::json OptionalJson(const std::optional<std::string>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

}  // namespace

std::string UtcIso8601FromSeconds(std::int64_t unix_seconds) {
  const std::time_t t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
  return buf;
}

std::optional<std::int64_t> SecondsFromUtcIso8601(const std::string& text) {
  std::tm tm{};
  char z = 0;
  int consumed = 0;
  if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%c%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday,
                  &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &z, &consumed) != 7 ||
      z != 'Z' || static_cast<std::size_t>(consumed) != text.size()) {
    return std::nullopt;
  }
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<std::int64_t>(timegm(&tm));
}

std::uint64_t TokenRevocations() {
  return g_revocations.load();
}

void TokenUseRecorder::Note(TokenId token_id) {
  const std::int64_t now = NowSeconds();
  {
    std::lock_guard lock(mu_);
    auto& last = stored_[token_id];
    if (last != 0 && now - last < kTokenUseResolutionS) return;
    last = now;
  }
  try {
    store_.TouchToken(token_id, UtcIso8601FromSeconds(now));
  } catch (const std::exception&) {
    // The request it belongs to goes on: a busy or failing database is reported by the
    // request's own reads and writes, and the next use after the resolution tries again.
  }
}

Caller Authenticate(AccessStore& storage, const std::string& token_sha256) {
  const auto t = storage.FindToken(token_sha256);
  if (!t) throw Unauthorized("the token is not valid");
  if (t->revoked_at) throw Unauthorized("the token was revoked at " + *t->revoked_at);
  Caller c;
  c.token_id = t->id;
  c.name = t->name;
  if (t->expires_at) {
    c.expires_unix = SecondsFromUtcIso8601(*t->expires_at);
    if (!c.expires_unix || NowSeconds() >= *c.expires_unix) {
      throw Unauthorized("the token expired at " + *t->expires_at);
    }
  }
  const auto role = ParseRole(t->role);
  if (!role) throw Unauthorized("the token has no known role");
  c.role = *role;
  return c;
}

nlohmann::json AccessService::CreateToken(const nlohmann::json& req) {
  if (!req.is_object()) throw InvalidInput(request::kFile, 0, "", "the body must be a JSON object");
  const std::string name = TokenName(req);
  const std::string role_text = request::RequiredString(req, "role");
  const auto role = ParseRole(role_text);
  if (!role) {
    throw InvalidInput(request::kFile, 0, "role",
                       "'" + role_text + "' is none of viewer, operator, engineer, admin");
  }
  std::optional<std::string> expires_at;
  if (req.contains("expires_in_s") && !req["expires_in_s"].is_null()) {
    const auto s = request::WholeNumber(req, "expires_in_s", 1, kMaxExpiresInS);
    expires_at = UtcIso8601FromSeconds(NowSeconds() + s);
  }
  for (const auto& [key, value] : req.items()) {
    if (key != "name" && key != "role" && key != "expires_in_s") {
      throw InvalidInput(request::kFile, 0, key, "is not a field of a token request");
    }
  }
  const std::string secret = NewRandomToken();
  const auto id = store_.AddToken(Sha256Hex(secret), RoleName(*role), name, expires_at);
  return {{"id", id},
          {"token", secret},
          {"name", name},
          {"role", RoleName(*role)},
          {"expires_at", OptionalJson(expires_at)}};
}

nlohmann::json AccessService::ListTokens() {
  const auto now = NowSeconds();
  nlohmann::json items = nlohmann::json::array();
  for (const auto& t : store_.ListTokens()) {
    items.push_back({{"id", t.id},
                     {"name", t.name},
                     {"role", t.role},
                     {"created_at", t.created_at},
                     {"expires_at", OptionalJson(t.expires_at)},
                     {"revoked_at", OptionalJson(t.revoked_at)},
                     {"last_used_at", OptionalJson(t.last_used_at)},
                     {"state", TokenState(t, now)}});
  }
  return {{"items", items}};
}

namespace {

// Refuses to revoke an active admin token unless another active admin token without an expiry
// remains: an expiring one would leave the service without an admin when it expires.
void CheckAnAdminRemains(const std::vector<TokenRecord>& tokens, TokenId id) {
  const auto now = NowSeconds();
  const TokenRecord* target = nullptr;
  int lasting_admins = 0;
  for (const auto& t : tokens) {
    if (t.id == id) {
      target = &t;
    } else if (ParseRole(t.role) == Role::kAdmin && !t.expires_at &&
               TokenState(t, now) == "active") {
      ++lasting_admins;
    }
  }
  if (!target) throw NotFound("there is no token " + to_string(id));
  if (ParseRole(target->role) == Role::kAdmin && TokenState(*target, now) == "active" &&
      lasting_admins == 0) {
    throw Conflict("token " + to_string(id) +
                   " is the last active admin token without an expiry (an expiring admin token "
                   "does not count): create another admin token without expires_in_s first, or "
                   "recover with kinemetricd --reset-admin (docs/operations.md)");
  }
}

}  // namespace

nlohmann::json AccessService::RevokeToken(TokenId id) {
  store_.RevokeToken(
      id, [id](const std::vector<TokenRecord>& tokens) { CheckAnAdminRemains(tokens, id); });
  ++g_revocations;
  for (const auto& t : store_.ListTokens()) {
    if (t.id == id) return {{"id", id}, {"revoked_at", OptionalJson(t.revoked_at)}};
  }
  return {{"id", id}, {"revoked_at", nullptr}};
}

void AccessService::RecordAudit(const AuditEntry& entry) {
  store_.AppendAudit(entry);
}

nlohmann::json AccessService::AuditLog(std::int64_t limit, std::int64_t offset) {
  const auto page = store_.ListAudit(limit, offset);
  nlohmann::json items = nlohmann::json::array();
  for (const auto& e : page.items) {
    items.push_back({{"id", e.id},
                     {"at", e.at},
                     {"token_id", IdOrNull(e.token_id)},
                     {"token_name", e.token_name},
                     {"role", e.role},
                     {"method", e.method},
                     {"path", e.path},
                     {"status", e.status},
                     {"subject", e.subject}});
  }
  return {{"items", items}, {"total", page.total}, {"limit", limit}, {"offset", offset}};
}

bool AccessService::TokenKnown(const std::string& token_sha256) {
  return store_.FindTokenRole(token_sha256).has_value();
}

std::string AccessService::EnsureAdminToken(const std::string& bootstrap) {
  return server::EnsureAdminToken(store_, bootstrap);
}

std::string EnsureAdminToken(AccessStore& storage, const std::string& bootstrap) {
  if (storage.CountTokens() > 0) return {};
  if (!bootstrap.empty()) {
    storage.PutToken(Sha256Hex(bootstrap), "admin", "bootstrap");
    return {};
  }
  const std::string token = NewRandomToken();
  storage.PutToken(Sha256Hex(token), "admin", "generated at first start");
  return token;
}

}  // namespace km::server
