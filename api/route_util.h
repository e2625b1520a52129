// Small helpers shared by the route files: query parameters and OpenAPI fragments.
#pragma once

#include <charconv>
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"
#include "api/http.h"
#include "api/http_target.h"
#include "ingest/json_text.h"
#include "server/base/time_util.h"

namespace km::api {

using nlohmann::json;

inline std::int64_t QueryInt(const Request& req, const std::string& key, std::int64_t fallback,
                             std::int64_t lo, std::int64_t hi) {
  const auto v = req.Query(key);
  if (!v) return fallback;
  std::int64_t n = 0;
  const auto [ptr, ec] = std::from_chars(v->data(), v->data() + v->size(), n);
  if (ec != std::errc() || ptr != v->data() + v->size() || n < lo || n > hi) {
    throw InvalidInput("", 0, key,
                       "'" + *v + "' must be a whole number from " + std::to_string(lo) + " to " +
                           std::to_string(hi));
  }
  return n;
}

inline std::optional<std::string> QueryTime(const Request& req, const std::string& key) {
  const auto v = req.Query(key);
  if (!v) return std::nullopt;
  auto t = server::NormaliseIso8601(*v);
  if (!t) throw InvalidInput("", 0, key, "'" + *v + "' is not an ISO 8601 date or time");
  return t;
}

inline json Param(const std::string& name, const std::string& type,
                  const std::string& description) {
  return {{"name", name},
          {"in", "query"},
          {"required", false},
          {"description", description},
          {"schema", {{"type", type}}}};
}

// An OpenAPI request body of JSON with this schema.
inline json JsonRequestBody(json schema, bool required = true) {
  return {{"required", required},
          {"content", {{"application/json", {{"schema", std::move(schema)}}}}}};
}

inline json JsonResponse(const std::string& description) {
  return {{"description", description},
          {"content", {{"application/json", {{"schema", {{"type", "object"}}}}}}}};
}

// The X-Filename of an upload: shown in messages and lists, so it must be printable text.
inline std::string UploadFilename(const Request& req) {
  const auto name = req.Header("x-filename");
  if (!name || name->empty()) return "upload";
  const auto refuse = [](const std::string& why) {
    throw InvalidInput("", 0, "X-Filename", "the X-Filename header " + why);
  };
  if (name->size() > 255) refuse("is longer than 255 bytes");
  if (!IsUtf8(*name)) refuse("is not valid UTF-8");
  for (const char c : *name) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7F) refuse("holds a control character");
  }
  return *name;
}

// Requests that name a few fields (a stream to open, a stretch of one, a device): 256 KiB.
inline constexpr std::size_t kSmallRequestBytes = 256u << 10;

// Study requests name stored measurements (ids), so their bodies are small.
inline constexpr std::size_t kStudyRequestBytes = 256u << 10;

// The request body as JSON (ingest/json_text.h: nesting depth, repeated keys and numbers
// beyond a double are refused as well); InvalidInput naming the field when it is not.
inline json JsonBody(const Request& req) {
  return ingest::ParseJsonText(req.body, "request");
}

}  // namespace km::api
