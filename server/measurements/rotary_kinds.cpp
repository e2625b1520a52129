#include "server/measurements/rotary_kinds.h"

#include <utility>

#include "analysis/core/errors.h"
#include "ingest/rotary/rotary_parser.h"
#include "server/base/finite_result.h"
#include "usecases/rotary/rotary_report.h"

namespace km::server {

Ingested IngestRotary(std::string_view bytes, const std::string& file,
                      const InstrumentHook& instruments) {
  ingest::RotaryFile f = ingest::ParseRotaryFile(bytes, file);
  Ingested in;
  in.kind = "rotary";
  in.machine_id = f.machine_id;
  in.test_id = f.test_id;
  for (const auto& [k, v] : f.metadata) in.metadata[k] = v;  // the file's own keys
  if (!f.timestamp.empty()) in.measured_at = f.timestamp;
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  // The poses as measured, in file order: the tilt (A or B) and C angles, the displacement.
  in.samples.columns = {"tilt_deg", "c_deg", "dx_um", "dy_um", "dz_um"};
  in.samples.values.reserve(5 * f.test.poses.size());
  for (const auto& p : f.test.poses) {
    in.samples.values.insert(in.samples.values.end(),
                             {p.tilt_deg, p.c_deg, p.d_um[0], p.d_um[1], p.d_um[2]});
  }
  const usecases::RotaryReport report =
      InFile(file, [&] { return usecases::AnalyzeRotary(std::move(f)); });
  nlohmann::json result = usecases::RotaryReportToJson(report);
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back(NewResult{"rotary", usecases::kRotaryAnalysisVersion, result.dump()});
  return in;
}

}  // namespace km::server
