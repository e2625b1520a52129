// kinemetric-positioning/1 parser (ingest/positioning_parser.h) and the analysis of an accepted
// file (usecases/positioning_report.h). Invariants: every accepted reading has a finite target
// and deviation and a direction of ±1; an analysed file has finite figures, A ≥ E ≥ M ≥ 0,
// R ≥ R↑, R↓, and a compensation entry per target.
#include <cmath>

#include "ingest/positioning_parser.h"
#include "tests/fuzz/fuzz_util.h"
#include "usecases/positioning_export.h"
#include "usecases/positioning_report.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto f = km::ingest::ParsePositioningFile(km::fuzz::AsText(data, size), "fuzz.txt");
    for (const auto& r : f.readings) {
      km::fuzz::Check(std::isfinite(r.target_mm) && std::isfinite(r.deviation_um), "finite");
      km::fuzz::Check(r.direction == 1 || r.direction == -1, "direction");
    }
    const auto report = km::usecases::AnalyzePositioning(f);
    const auto& iso = report.figures.iso;
    km::fuzz::Check(std::isfinite(iso.accuracy_um), "finite A");
    km::fuzz::Check(iso.accuracy_um + 1e-9 >= iso.systematic_deviation_um, "A >= E");
    km::fuzz::Check(iso.systematic_deviation_um + 1e-9 >= iso.mean_deviation_range_um, "E >= M");
    km::fuzz::Check(iso.repeatability_um + 1e-9 >= iso.repeatability_up_um, "R >= R up");
    km::fuzz::Check(iso.repeatability_um + 1e-9 >= iso.repeatability_down_um, "R >= R down");
    km::fuzz::Check(report.compensation.target_mm.size() == report.figures.targets.size(),
                    "a trim per target");
    km::usecases::PositioningReportToJson(report).dump();
    km::usecases::ExportLinuxCnc(report);
    km::usecases::ExportCompensationCsv(report);
    if (report.figures.targets.size() >= 2) km::usecases::ExportSinumerik(report);
  });
  return 0;
}
