#include "server/measurements/servo_kinds.h"

#include "analysis/core/errors.h"
#include "ingest/servo_parser.h"
#include "server/base/finite_result.h"
#include "usecases/servo_report.h"

namespace km::server {

Ingested IngestServo(std::string_view bytes, const std::string& file,
                     const InstrumentHook& instruments) {
  servo::ServoFile f = ingest::ParseServoFile(bytes, file);
  Ingested in;
  in.kind = "servo";
  in.machine_id = f.machine_id;
  in.test_id = f.test_id;
  in.direction = f.direction;
  for (const auto& [k, v] : f.metadata) in.metadata[k] = v;
  if (auto it = f.metadata.find("timestamp"); it != f.metadata.end()) in.measured_at = it->second;
  const auto use = UseInstrument(instruments, f.metadata, in.measured_at);
  SampleBlock& b = in.samples;
  b.columns = {"t_s"};
  if (f.hexapod) {
    for (const char* c : {"x_mm", "y_mm", "z_mm", "a_deg", "b_deg", "c_deg", "f1_N", "f2_N", "f3_N",
                          "f4_N", "f5_N", "f6_N"}) {
      b.columns.push_back(c);
    }
    b.values.reserve(f.samples.size() * b.columns.size());
    for (const auto& s : f.samples) {
      b.values.push_back(s.t_s);
      b.values.insert(b.values.end(), s.tip_mm.begin(), s.tip_mm.end());
      b.values.insert(b.values.end(), s.abc_deg.begin(), s.abc_deg.end());
      b.values.insert(b.values.end(), s.force_N.begin(), s.force_N.end());
    }
  } else {
    for (const auto& a : f.axes) {
      b.columns.push_back("pos_" + a.axis + "_mm");
      b.columns.push_back("force_" + a.axis + "_N");
    }
    for (std::size_t i = 0; i < f.t_s.size(); ++i) {
      b.values.push_back(f.t_s[i]);
      for (const auto& a : f.axes) {
        b.values.push_back(a.pos_mm[i]);
        b.values.push_back(a.force_N[i]);
      }
    }
  }
  nlohmann::json result = usecases::ServoSummaryJson(f);
  RequireFiniteResult(result, file);
  AddInstrumentUse(use, result);
  in.results.push_back({"servo", usecases::kServoAnalysisVersion, result.dump()});
  return in;
}

}  // namespace km::server
