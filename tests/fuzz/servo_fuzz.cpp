// kinemetric-servo/1 parser (ingest/servo_parser.h) and the upload summary
// (usecases/servo_report.h). Invariants: an accepted record has at least kMinServoRows rows with
// strictly increasing finite times, finite poses and forces, six forces a hexapod row, equal
// lengths per feed-drive axis; its summary is finite.
#include <cmath>

#include "ingest/servo_parser.h"
#include "tests/fuzz/fuzz_util.h"
#include "usecases/servo_report.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  km::fuzz::Guarded([&] {
    const auto f = km::ingest::ParseServoFile(km::fuzz::AsText(data, size), "fuzz.txt");
    const std::size_t n = f.t_s.size();
    km::fuzz::Check(n >= km::ingest::kMinServoRows, "enough rows");
    for (std::size_t i = 0; i < n; ++i) {
      km::fuzz::Check(std::isfinite(f.t_s[i]), "finite time");
      if (i) km::fuzz::Check(f.t_s[i] > f.t_s[i - 1], "increasing time");
    }
    km::fuzz::Check(f.lines.size() == n, "a line per row");
    if (f.hexapod) {
      km::fuzz::Check(f.samples.size() == n, "a sample per row");
      for (const auto& s : f.samples) {
        for (double v : s.force_N) km::fuzz::Check(std::isfinite(v), "finite force");
        for (double v : s.tip_mm) km::fuzz::Check(std::isfinite(v), "finite position");
      }
    } else {
      km::fuzz::Check(!f.axes.empty(), "an axis");
      for (const auto& a : f.axes) {
        km::fuzz::Check(a.pos_mm.size() == n && a.force_N.size() == n, "axis length");
        for (double v : a.force_N) km::fuzz::Check(std::isfinite(v), "finite force");
      }
    }
    const auto j = km::usecases::ServoSummaryJson(f);
    km::fuzz::Check(j["samples"].get<std::size_t>() == n, "summary sample count");
  });
  return 0;
}
