// The diagnosis's option checks, entries and traces (diagnosis.h); the diagnosis itself is in
// diagnosis.cpp.
#include "analysis/core/angles.h"
#include "analysis/dbb/diagnosis.h"

#include <algorithm>
#include <numbers>
#include <vector>

#include "analysis/core/errors.h"
#include "analysis/dbb/circular_test.h"
#include "analysis/dbb/iso230.h"

namespace km::dbb {

namespace {}  // namespace

void DiagnosisOptions::Check() const {
  if (!(significance > 0.0)) throw InvalidInput("", 0, "significance", "must be positive");
  if (min_contribution_pct < 0.0 || min_contribution_pct > 100.0) {
    throw InvalidInput("", 0, "min_contribution_pct", "must be within 0…100");
  }
  if (!(confound_ratio > 0.0 && confound_ratio < 1.0)) {
    throw InvalidInput("", 0, "confound_ratio", "must be within (0, 1)");
  }
  if (!(spike_min_width_deg > 0.0 && spike_max_width_deg > spike_min_width_deg)) {
    throw InvalidInput("", 0, "spike_min_width_deg", "need 0 < min < max width");
  }
  if (!(cyclic_min_period_mm > 0.0)) throw InvalidInput("", 0, "cyclic_min_period_mm", "> 0");
  if (!(stick_slip_min_period_deg > 0.0 && stick_slip_max_period_deg > stick_slip_min_period_deg)) {
    throw InvalidInput("", 0, "stick_slip_min_period_deg", "need 0 < min < max period");
  }
  if (!(stick_slip_max_step_deg > 0.0)) {
    throw InvalidInput("", 0, "stick_slip_max_step_deg", "must be positive");
  }
  if (!(stick_slip_detection_chi2 > 0.0)) {
    throw InvalidInput("", 0, "stick_slip_detection_chi2", "must be positive");
  }
}

double DiagnosisEntry::MaxContribution() const {
  double m = 0.0;
  for (double c : contribution_pct) m = std::max(m, c);
  return m;
}

std::pair<char, char> AxisLetters(Plane plane) {
  switch (plane) {
    case Plane::kYZ:
      return {'y', 'z'};
    case Plane::kZX:
      return {'z', 'x'};
    case Plane::kXY:
    default:
      return {'x', 'y'};
  }
}

DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result) {
  return MakeDiagnosisTrace(test, result, DeviationAboutNominalCentre(result));
}

DiagnosisTrace MakeDiagnosisTrace(const DbbTest& test, const CircularTestResult& result,
                                  const std::vector<double>& dev) {
  if (dev.size() != result.angle_deg.size()) {
    throw InvalidInput("", 0, "dr_um", "deviation and angle sizes differ");
  }
  DiagnosisTrace t;
  t.direction = test.direction;
  t.radius_mm = test.radius_mm;
  t.feed_mm_min = test.feed_mm_min;
  const double k = test.bar_length_mm / test.radius_mm;  // bar → in-plane radial (cone tests)
  t.dev_um = dev;
  for (double& d : t.dev_um) d *= k;
  const std::size_t n = result.angle_deg.size();
  t.angle_rad.resize(n);
  for (std::size_t i = 0; i < n; ++i) t.angle_rad[i] = result.angle_deg[i] * kDeg;
  if (result.cos_angle.size() == n && result.sin_angle.size() == n) {
    t.cos_angle = result.cos_angle;
    t.sin_angle = result.sin_angle;
    return t;
  }
  t.cos_angle.resize(n);
  t.sin_angle.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    t.cos_angle[i] = CosAngle(result, i);
    t.sin_angle[i] = SinAngle(result, i);
  }
  return t;
}

}  // namespace km::dbb
