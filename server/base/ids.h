// The ids of the stored tables, one type a table, so that a job's id is never passed where a
// measurement's is expected. An id is the table's integer key: constructed explicitly from it
// (at the SQL boundary and from a request's path), read back with value(), written to JSON and
// read from it as that plain integer, so that no answer and no stored document changes. "No id"
// is std::optional<…Id>; a default-constructed id (0) is only a record's id before the storage
// has set it.
#pragma once

#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

namespace km::server {

template <class Tag>
class Id {
 public:
  constexpr Id() = default;
  constexpr explicit Id(std::int64_t value) : value_(value) {}

  constexpr std::int64_t value() const { return value_; }

  friend constexpr bool operator==(Id, Id) = default;
  friend constexpr auto operator<=>(Id, Id) = default;

  friend std::ostream& operator<<(std::ostream& os, Id id) { return os << id.value_; }
  friend std::string to_string(Id id) { return std::to_string(id.value_); }

  // nlohmann::json: the plain integer.
  friend void to_json(nlohmann::json& j, Id id) { j = id.value_; }
  friend void from_json(const nlohmann::json& j, Id& id) { id = Id(j.get<std::int64_t>()); }

 private:
  std::int64_t value_ = 0;
};

using MeasurementId = Id<struct MeasurementTag>;    // measurements (and their results)
using JobId = Id<struct JobTag>;                    // background jobs
using TokenId = Id<struct TokenTag>;                // access tokens
using StreamId = Id<struct StreamTag>;              // sensor streams (and their chunks, gaps)
using AuditVerdictId = Id<struct AuditVerdictTag>;  // accuracy-audit verdicts
using AuditEntryId = Id<struct AuditEntryTag>;      // the audit log of requests

// The integer of an optional id, 0 for none: for the answers and stored columns that spelled
// "none" as 0 before ids had types (their format does not change).
template <class Tag>
constexpr std::int64_t ValueOrZero(const std::optional<Id<Tag>>& id) {
  return id ? id->value() : 0;
}

// An optional id in an answer: its integer, or null for none.
template <class Tag>
nlohmann::json IdOrNull(const std::optional<Id<Tag>>& id) {
  return id ? nlohmann::json(id->value()) : nlohmann::json(nullptr);
}

// The optional id of such an integer: none for 0.
template <class IdType>
constexpr std::optional<IdType> IdOrNone(std::int64_t value) {
  if (value == 0) return std::nullopt;
  return IdType(value);
}

}  // namespace km::server

template <class Tag>
struct std::hash<km::server::Id<Tag>> {
  std::size_t operator()(km::server::Id<Tag> id) const noexcept {
    return std::hash<std::int64_t>{}(id.value());
  }
};
