// Shared helpers of the DBB analysis tests: simulated serial-machine cw/ccw pairs.
#pragma once

#include <vector>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/serial_sim.h"

namespace km::dbb::test {

inline std::vector<DbbTest> SimulatePair(SerialDbbSimOptions o, bool both = true) {
  std::vector<DbbTest> v;
  o.direction = Direction::kCcw;
  v.push_back(SimulateSerialDbbTest(o));
  if (both) {
    o.direction = Direction::kCw;
    o.seed += 7919;
    v.push_back(SimulateSerialDbbTest(o));
  }
  return v;
}

inline DiagnosisResult DiagnoseTests(const std::vector<DbbTest>& tests,
                                     const DiagnosisOptions& opt = {}) {
  std::vector<DiagnosisTrace> tr;
  for (const auto& t : tests) tr.push_back(MakeDiagnosisTrace(t, AnalyzeCircularTest(t)));
  return DiagnoseSerialDbb(tr, tests.front().plane, opt);
}

}  // namespace km::dbb::test
