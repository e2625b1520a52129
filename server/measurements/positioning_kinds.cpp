#include "server/measurements/positioning_kinds.h"

#include "analysis/core/errors.h"
#include "ingest/positioning_parser.h"
#include "server/base/finite_result.h"
#include "usecases/positioning_report.h"

namespace km::server {

Ingested IngestPositioning(std::string_view bytes, const std::string& file) {
  const ingest::PositioningFile f = ingest::ParsePositioningFile(bytes, file);
  usecases::PositioningReport report;
  try {
    report = usecases::AnalysePositioning(f);
  } catch (const InvalidInput& e) {
    if (!e.file().empty()) throw;
    throw InvalidInput(file, e.line(), e.field(), e.reason());  // name the file
  }
  const nlohmann::json result = usecases::PositioningReportToJson(report);
  RequireFiniteResult(result, file);
  Ingested in;
  in.kind = "positioning";
  in.machine_id = f.machine_id;
  in.test_id = f.axis;
  for (const auto& [k, v] : f.metadata) in.metadata[k] = v;
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
