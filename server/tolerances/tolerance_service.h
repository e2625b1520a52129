// The tolerance tables of the machines, versioned (docs/http.md "Tolerances and conformance"):
// PUT stores the next version of a machine's table (the same entries as the newest version give
// that version back, nothing stored), GET reads the newest or one version, and the judges give
// each measurement its conformance with its machine's newest table, on the fly, so a
// measurement is judged when it is stored and again whenever the table changes. The pure parts
// are server/tolerances/tolerances.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "server/measurements/conformance_hook.h"
#include "server/storage/storage.h"
#include "server/tolerances/tolerances.h"

namespace km::server {

// The machine's tolerance table: the given version, or the newest without one; nullopt when
// there is none (no table, or no such version).
std::optional<ToleranceTable> ReadToleranceTable(
    ToleranceStore& store, const std::string& machine_id,
    std::optional<std::int64_t> version = std::nullopt);

class ToleranceService {
 public:
  explicit ToleranceService(ToleranceStore& store) : store_(store) {}

  // PUT /api/v1/machines/{machine_id}/tolerances: {machine_id, version, tolerances, created_at,
  // created}. km::InvalidInput naming the field (machine_id, tolerances[i].key, …).
  nlohmann::json Put(const std::string& machine_id, const nlohmann::json& body);
  // GET …/tolerances[?version=N]: {machine_id, version, tolerances, created_at}; NotFound
  // when the machine has no table (or not that version).
  nlohmann::json Get(const std::string& machine_id, std::optional<std::int64_t> version);

  // Judges over the newest tables, for the measurement service: each judge reads a machine's
  // newest table at its first measurement of that machine and keeps it.
  ConformanceJudges Judges();

 private:
  ToleranceStore& store_;
};

}  // namespace km::server
