// Shared helpers of the DBB analysis tests: simulated serial-machine cw/ccw pairs.
#pragma once

#include <string>
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

// The named effects of a diagnosis as text, for the message of a failing check.
inline std::string Describe(const DiagnosisResult& r) {
  std::string s;
  for (const auto& e : r.named) {
    s += e.effect + "=" + std::to_string(e.value[0]) + "±" + std::to_string(e.uncertainty[0]) +
         " (" + std::to_string(e.MaxContribution()) + "%)";
    for (const auto& [k, v] : e.shape) s += " " + k + "=" + std::to_string(v);
    for (const auto& [k, v] : e.shape_uncertainty) s += " u(" + k + ")=" + std::to_string(v);
    if (!e.shape_kind.empty()) s += " " + e.shape_kind;
    s += "; ";
  }
  s += "| not identifiable:";
  for (const auto& n : r.not_identifiable) s += " " + n + ";";
  return s;
}

inline const DiagnosisEntry* Named(const DiagnosisResult& r, const std::string& name) {
  for (const auto& e : r.named)
    if (e.effect == name) return &e;
  return nullptr;
}

}  // namespace km::dbb::test
