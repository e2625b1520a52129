// Fields of a JSON API request, checked one way everywhere: a missing or ill-typed field is a
// km::InvalidInput with file "request" and the field's key, saying what was expected.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "analysis/core/errors.h"

namespace km::server::request {

inline constexpr const char* kFile = "request";

inline std::string RequiredString(const nlohmann::json& j, const std::string& key) {
  if (!j.contains(key) || !j[key].is_string() || j[key].get<std::string>().empty()) {
    throw InvalidInput(kFile, 0, key, "a non-empty string is required");
  }
  return j[key].get<std::string>();
}

inline std::string OptionalString(const nlohmann::json& j, const std::string& key,
                                  const std::string& fallback) {
  if (!j.contains(key)) return fallback;
  if (!j[key].is_string()) throw InvalidInput(kFile, 0, key, "must be a string");
  return j[key].get<std::string>();
}

// A finite number; without a fallback the field is required.
inline double Number(const nlohmann::json& j, const std::string& key,
                     std::optional<double> fallback) {
  if (!j.contains(key)) {
    if (!fallback) throw InvalidInput(kFile, 0, key, "a number is required");
    return *fallback;
  }
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>())) {
    throw InvalidInput(kFile, 0, key, "must be a finite number");
  }
  return j[key].get<double>();
}

// A whole number in [lo, hi]; without a fallback the field is required.
inline std::int64_t WholeNumber(const nlohmann::json& j, const std::string& key, std::int64_t lo,
                                std::int64_t hi,
                                std::optional<std::int64_t> fallback = std::nullopt) {
  if (!j.contains(key)) {
    if (!fallback) throw InvalidInput(kFile, 0, key, "a whole number is required");
    return *fallback;
  }
  // A whole number above the int64 range arrives unsigned; read as int64 it would wrap around.
  const bool beyond_int64 = j[key].is_number_unsigned() &&
                            j[key].get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX);
  if (!j[key].is_number_integer() || beyond_int64 || j[key].get<std::int64_t>() < lo ||
      j[key].get<std::int64_t>() > hi) {
    throw InvalidInput(
        kFile, 0, key,
        "must be a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
  }
  return j[key].get<std::int64_t>();
}

}  // namespace km::server::request
