// One entry point for the DBB analysis of a set of tests (CLI `dbb analyze`, API results):
//
//  per test   circular-test figures (circular_test.h, [PM-600 report] eqs. 4.6–4.8), minimum-zone
//             circularity (analysis/geometry/min_zone_circle.h), ISO 230-4 figures (iso230.h),
//             harmonics of the radial error (harmonics.h) and the named diagnosis (diagnosis.h);
//  per pair   one cw + one ccw test with the same test_id: circular hysteresis and
//             bidirectional circular deviation; the pair is diagnosed jointly (how an effect
//             looks in both directions is what separates e.g. servo mismatch from squareness).
//
// Every deviation of the report (circular figures, minimum zone, ISO 230-4 figures of tests and
// pairs, harmonics, polar plot) is in tool-path units: the bar deviation × R_DBB / R, radial in
// the plane of the circle (circular_test.h DeviationUnits::kToolPath; factor 1 for a flat test),
// as the diagnosis reports its effects.
//
// Harmonics use the deviation the test evaluates: about the least-squares circle
// (centre_corrected) or about the nominal centre (absolute, where the first order is the
// machine's centre positioning error). Minimum zone is computed on the planar representation
// about the nominal centre, started from the least-squares centre.
//
// servo_lag vs radius_error: both are constant radius changes in one test; they are separated
// only when the set holds tests of the same machine, plane, radius and centre at different
// feeds: the units' mean radius changes m_i are regressed as m_i = ρ + c·g_i with
// g_i = −V_i²/(2R) ([Fujita thesis] eq. 2.1, c = (1 − K_f²)/K_pp²); then radius_error = ρ and
// servo_lag = c·g_i for each test. Otherwise the whole mean change is reported as radius_error.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/dbb_types.h"
#include "analysis/dbb/diagnosis.h"
#include "analysis/dbb/harmonics.h"
#include "analysis/dbb/iso230.h"
#include "analysis/geometry/min_zone_circle.h"

namespace km::dbb {

struct DbbTestReport {
  CircularTestResult circular;  // lead's figures (first six JSON keys), tool-path units
  double min_zone_circularity_um = 0.0;
  geometry::MinZoneCircleResult min_zone;  // µm, about the nominal centre
  Iso230Figures iso230_4;
  HarmonicsResult harmonics;
  std::vector<DiagnosisEntry> diagnosis;  // named effects, ranked for this test;
                                          // contribution_pct[0] is this test's
  std::vector<std::string> not_identifiable;
  Plane plane = Plane::kXY;
  std::optional<std::size_t> pair;  // index into DbbReport::pairs
};

struct DbbPairReport {
  std::string test_id;
  std::size_t cw = 0;  // test indices (input order)
  std::size_t ccw = 0;
  Iso230PairFigures iso230_4;
};

struct DbbReport {
  std::vector<DbbTestReport> tests;  // input order
  std::vector<DbbPairReport> pairs;
};

struct DbbAnalysisOptions {
  int harmonic_orders = 10;
  bool diagnose = true;
  DiagnosisOptions diagnosis;
  // Threads for the independent parts (the tests' figures, the pairs, the diagnosis units):
  // 0 = the machine's cores, 1 = in order on the calling thread. The result is the same.
  unsigned threads = 0;
  void Check() const;  // throws km::InvalidInput naming the option out of its range
};

// Throws km::InvalidInput for unusable tests (the message names the test_id).
DbbReport AnalyzeDbbSet(const std::vector<DbbTest>& tests, const DbbAnalysisOptions& options = {});

}  // namespace km::dbb
