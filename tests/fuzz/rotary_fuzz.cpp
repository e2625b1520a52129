// kinemetric-rotary/1 parser (ingest/rotary/rotary_parser.h) and the analysis of an accepted file
// (usecases/rotary/rotary_report.h: the location errors, their Monte Carlo uncertainty when the
// file states u_reading_um). Invariants: every accepted pose is finite and the first is at zero
// angles; an analysed file has finite RMS before and after, a rank of at most 8, a finite value
// and σ for every error the poses determine, one residual per pose, and a JSON answer.
#include <cmath>

#include "ingest/rotary/rotary_parser.h"
#include "tests/fuzz/fuzz_util.h"
#include "usecases/rotary/rotary_report.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    auto f = km::ingest::ParseRotaryFile(km::fuzz::AsText(data, size), "fuzz.txt");
    const std::size_t poses = f.lines.size();
    const auto report = km::usecases::AnalyzeRotary(std::move(f));
    const auto& r = report.result;
    km::fuzz::Check(std::isfinite(r.measured_rms_um) && std::isfinite(r.residual_rms_um),
                    "finite RMS");
    km::fuzz::Check(r.rank <= r.errors.size(), "rank of at most 8");
    km::fuzz::Check(r.residuals_um.size() == poses, "a residual per pose");
    for (const auto& e : r.errors) {
      if (e.identifiable) {
        km::fuzz::Check(std::isfinite(e.value) && std::isfinite(e.sigma), "finite error");
      }
    }
    km::usecases::RotaryReportToJson(report).dump();
  });
  return 0;
}
