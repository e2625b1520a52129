// What the accuracy audits and the fleet view read, and nothing more: the stored records and
// the CW/CCW pair analysis of a stored DBB test. The service (server/service.h) is one; the
// audits do not see the rest of it.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "server/storage/storage.h"

namespace km::server {

class AuditSource {
 public:
  virtual ~AuditSource() = default;
  virtual Storage& storage() = 0;
  // The pair analysis of a stored DBB test, recomputed from its stored bytes; null when the
  // test has no partner (MeasurementService::DbbPairJson).
  virtual nlohmann::json DbbPairJson(std::int64_t id) = 0;
};

}  // namespace km::server
