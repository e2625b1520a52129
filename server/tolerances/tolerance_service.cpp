#include "server/tolerances/tolerance_service.h"

#include <map>
#include <memory>

#include "analysis/core/errors.h"
#include "ingest/identifiers.h"
#include "ingest/json_text.h"
#include "server/base/sha256.h"

namespace km::server {
namespace {

// A stored table parsed again as it was validated when stored: {"tolerances", "decision_rule"},
// or (stored before decision rules) the array of entries alone.
ToleranceTable TableOf(const ToleranceTableRecord& r) {
  nlohmann::json stored = ingest::ParseJsonText(r.tolerances_json, "stored tolerance table");
  if (stored.is_array()) stored = {{"tolerances", std::move(stored)}};
  return {r.machine_id, r.version, r.created_at, ParseToleranceBody(stored),
          ParseToleranceDecisionRule(stored)};
}

}  // namespace

std::optional<ToleranceTable> ReadToleranceTable(ToleranceStore& store,
                                                 const std::string& machine_id,
                                                 std::optional<std::int64_t> version) {
  const auto r = store.GetToleranceTable(machine_id, version);
  if (!r) return std::nullopt;
  return TableOf(*r);
}

nlohmann::json ToleranceService::Put(const std::string& machine_id, const nlohmann::json& body) {
  ingest::CheckMachineId(machine_id, "", 0);
  const std::vector<ToleranceEntry> entries = ParseToleranceBody(body);
  const DecisionRule rule = ParseToleranceDecisionRule(body);
  NewToleranceTable t;
  t.machine_id = machine_id;
  t.tolerances_json = StoredToleranceJson(entries, rule).dump();
  t.sha256 = Sha256Hex(CanonicalToleranceText(entries, rule));
  const auto put = store_.PutToleranceTable(t);
  nlohmann::json out = ToleranceTableJson(TableOf(put.record));
  out["created"] = put.created;
  return out;
}

nlohmann::json ToleranceService::Get(const std::string& machine_id,
                                     std::optional<std::int64_t> version) {
  ingest::CheckMachineId(machine_id, "", 0);
  const auto table = ReadToleranceTable(store_, machine_id, version);
  if (table) return ToleranceTableJson(*table);
  if (!version) throw NotFound("machine '" + machine_id + "' has no tolerance table");
  const auto newest = store_.GetToleranceTable(machine_id, std::nullopt);
  throw NotFound("machine '" + machine_id + "' has no tolerance table version " +
                 std::to_string(*version) +
                 (newest ? "; the newest is version " + std::to_string(newest->version)
                         : "; it has no tolerance table"));
}

ConformanceJudges ToleranceService::Judges() {
  ToleranceStore* store = &store_;
  return [store]() -> ConformanceJudge {
    auto tables = std::make_shared<std::map<std::string, ToleranceTable>>();
    return [store, tables](const ConformanceSubject& s, const nlohmann::json& result) {
      auto it = tables->find(s.machine_id);
      if (it == tables->end()) {
        ToleranceTable none;
        none.machine_id = s.machine_id;
        it = tables->emplace(s.machine_id, ReadToleranceTable(*store, s.machine_id).value_or(none))
                 .first;
      }
      return Conformance(it->second, s.kind, s.test_id, s.direction, result);
    };
  };
}

}  // namespace km::server
