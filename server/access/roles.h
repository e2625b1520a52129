// The roles of access tokens, each allowed everything of the roles below it: viewer (read),
// operator (+ upload measurements, open and feed streams), engineer (+ calibrations,
// discoveries, cancelling its own jobs, machine definitions, servo identification, audit rules
// and schedules), admin (+ tokens, devices, cancelling any job, the audit log). kPublic marks
// routes that need no token at all.
#pragma once

#include <optional>
#include <string_view>

namespace km::server {

enum class Role { kPublic = 0, kViewer = 1, kOperator = 2, kEngineer = 3, kAdmin = 4 };

inline const char* RoleName(Role r) {
  switch (r) {
    case Role::kPublic:
      return "public";
    case Role::kViewer:
      return "viewer";
    case Role::kOperator:
      return "operator";
    case Role::kEngineer:
      return "engineer";
    case Role::kAdmin:
      return "admin";
  }
  return "admin";
}

// A token role by name (viewer, operator, engineer, admin); nullopt for anything else.
inline std::optional<Role> ParseRole(std::string_view name) {
  for (const Role r : {Role::kViewer, Role::kOperator, Role::kEngineer, Role::kAdmin}) {
    if (name == RoleName(r)) return r;
  }
  return std::nullopt;
}

}  // namespace km::server
