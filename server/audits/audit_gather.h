// The evidence of an accuracy audit, read from storage: for every rule, each set-up of the
// machine it applies to (server/audits/set_up.h), with the value of the set-up's newest test
// and, for trend rules, the reference value of the same set-up.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/audits/accuracy_audit.h"
#include "server/audits/audit_source.h"
#include "server/audits/audit_verdict.h"

namespace km::server {

// How many of a machine's newest measurements of a kind an audit looks through.
inline constexpr std::int64_t kAuditHistory = 2000;

// The evidence of every rule (same order) at `now`; `previous` is the machine's previous
// verdict (null when none), the reference of "previous_audit" trends.
std::vector<AuditEvidence> GatherAuditEvidence(AuditSource& service, const std::string& machine_id,
                                               const std::vector<AuditRule>& rules,
                                               const AuditPolicy& policy,
                                               const nlohmann::json& previous, std::int64_t now);

}  // namespace km::server
