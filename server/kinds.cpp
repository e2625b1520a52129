// The measurement kinds the server accepts, one handler per format (contract §1).
#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "ingest/dbb_parser.h"
#include "server/report.h"
#include "server/service.h"

namespace km::server {
namespace {

Ingested IngestDbb(std::string_view bytes, const std::string& file) {
  const dbb::DbbTest test = ingest::ParseDbb(bytes, file);
  dbb::CircularTestResult r;
  try {
    r = dbb::AnalyzeCircularTest(test);
  } catch (const InvalidInput& e) {
    // Analysis-level problems name the file too.
    throw InvalidInput(file, e.line(), e.field(), e.reason());
  }
  Ingested in;
  in.kind = "dbb";
  in.machine_id = test.machine_id;
  in.test_id = test.test_id;
  in.direction = dbb::ToString(test.direction);
  in.measured_at = test.timestamp;
  for (const auto& [k, v] : test.metadata) in.metadata[k] = v;
  in.samples.columns = {"angle_deg", "dr_um"};
  in.samples.values.reserve(2 * test.angle_deg.size());
  for (std::size_t i = 0; i < test.angle_deg.size(); ++i) {
    in.samples.values.push_back(test.angle_deg[i]);
    in.samples.values.push_back(test.dr_um[i]);
  }
  in.results.push_back(NewResult{"dbb", kDbbAnalysisVersion, DbbTestJson(test, r).dump()});
  return in;
}

}  // namespace

void RegisterBuiltinKinds(Service& service) {
  service.RegisterKind(ingest::kDbbFormat, IngestDbb);
}

nlohmann::json Service::DbbTrace(std::int64_t id) {
  const auto rec = storage_->GetMeasurement(id);
  if (!rec) throw NotFound("measurement " + std::to_string(id) + " does not exist");
  if (rec->kind != "dbb") {
    throw InvalidInput("", 0, "id", "measurement " + std::to_string(id) + " is not a DBB test");
  }
  const std::string raw = storage_->GetRaw(id);
  const dbb::DbbTest test = ingest::ParseDbb(raw, rec->filename);
  return DbbTraceJson(test, dbb::AnalyzeCircularTest(test));
}

}  // namespace km::server
