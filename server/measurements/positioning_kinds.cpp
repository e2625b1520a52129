#include "server/measurements/positioning_kinds.h"

#include "analysis/core/errors.h"
#include "ingest/positioning_parser.h"
#include "server/base/finite_result.h"
#include "usecases/positioning_report.h"

namespace km::server {
namespace {

// The register's air uncertainties act through the refractive index kinemetric applies to raw
// readings, its material ones through the correction to 20 °C: a file without that correction
// does not take them from the register (in the file itself the parser refuses them).
void DropInapplicableRegisterKeys(ingest::PositioningFile& f, std::optional<InstrumentUse>& use) {
  if (!use || !use->block.is_object()) return;
  nlohmann::json& sources = use->block["sources"];
  const auto drop = [&](const char* key) {
    if (sources.value(key, "") != "register") return;
    f.metadata.erase(key);
    sources.erase(key);
  };
  if (f.air_compensated) {
    for (const char* key : {"u_air_temperature_c", "u_air_pressure_pa", "u_air_humidity_pct"}) {
      drop(key);
    }
  }
  if (!f.corrections.material_temperature_c) {
    for (const char* key : {"u_material_temperature_c", "u_expansion_ppm_per_k"}) drop(key);
  }
}

}  // namespace

Ingested IngestPositioning(std::string_view bytes, const std::string& file,
                           const InstrumentHook& instruments) {
  ingest::PositioningFile f = ingest::ParsePositioningFile(bytes, file);
  const auto own_metadata = f.metadata;  // stored with the measurement
  auto use =
      UseInstrument(instruments, f.metadata,
                    f.timestamp.empty() ? std::nullopt : std::optional<std::string>(f.timestamp));
  DropInapplicableRegisterKeys(f, use);
  const usecases::PositioningReport report =
      InFile(file, [&] { return usecases::AnalyzePositioning(f); });
  nlohmann::json result = usecases::PositioningReportToJson(report);
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  Ingested in;
  in.kind = "positioning";
  in.machine_id = f.machine_id;
  in.test_id = f.axis;
  for (const auto& [k, v] : own_metadata) in.metadata[k] = v;
  if (!f.timestamp.empty()) in.measured_at = f.timestamp;
  // The readings as evaluated (air and material corrections applied), in the order measured.
  in.samples.columns = {"run", "direction", "target_mm", "deviation_um"};
  in.samples.values.reserve(4 * report.readings.size());
  for (const auto& r : report.readings) {
    in.samples.values.insert(in.samples.values.end(),
                             {static_cast<double>(r.run), static_cast<double>(r.direction),
                              r.target_mm, r.deviation_um});
  }
  in.results.push_back(
      NewResult{"positioning", usecases::kPositioningAnalysisVersion, result.dump()});
  return in;
}

}  // namespace km::server
