#include "analysis/rotary/rotary_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <span>

#include "analysis/core/errors.h"
#include "analysis/core/option_check.h"

namespace km::rotary {

void ReadingUncertaintyOptions::Check() const {
  KM_OPTION_GE(draws, 20u);
  KM_OPTION_GE(large_draws, 20u);
  KM_OPTION_GE(min_draws, 20u);
}

std::size_t ReadingDraws(std::size_t poses, const ReadingUncertaintyOptions& o) {
  if (poses <= o.large_poses) return o.draws;
  return std::max(o.min_draws, std::min(o.large_draws, o.max_pose_draws / poses));
}

ReadingUncertainty PropagateReadingUncertainty(const RotaryTest& test, double u_reading_um,
                                               const ReadingUncertaintyOptions& options,
                                               const IdentifyOptions& identify) {
  options.Check();
  if (!(u_reading_um > 0.0) || !std::isfinite(u_reading_um)) {
    throw InvalidInput("", 0, "u_reading_um", "must be a finite number > 0 to be propagated");
  }
  const Reidentification solver(test, identify);
  ReadingUncertainty out;
  out.readings = solver.Readings();
  const auto identifiable = solver.Identifiable();
  const LocationErrors per_unit = solver.SigmaPerUnitReading();
  for (std::size_t j = 0; j < kLocationErrorCount; ++j) {
    if (!identifiable[j]) continue;
    out.errors.push_back(j);
    out.u_gum.push_back(u_reading_um * per_unit[j]);
  }
  uncertainty::McOptions mo;
  mo.draws = ReadingDraws(test.poses.size(), options);
  mo.seed = options.seed;
  mo.budget_draws = 0;       // one input: its contribution is u itself
  if (out.errors.empty()) {  // nothing determined: nothing to propagate
    out.mc.draws = 0;
    out.mc.seed = mo.seed;
    return out;
  }
  const std::vector<double> measured = solver.MeasuredUm();
  std::vector<double> drawn(measured.size());
  const uncertainty::VectorModel model = [&](std::span<const double> x, std::span<double> y) {
    for (std::size_t i = 0; i < drawn.size(); ++i) drawn[i] = measured[i] + x[i];
    bool converged = true;
    const LocationErrors e = solver.Solve(drawn, &converged);
    if (!converged) ++out.unconverged_draws;
    for (std::size_t k = 0; k < out.errors.size(); ++k) y[k] = e[out.errors[k]];
  };
  out.mc = uncertainty::PropagateMonteCarlo(
      model, {uncertainty::McInput::NormalGroup("u_reading_um", 0.0, u_reading_um, out.readings)},
      out.errors.size(), mo);
  for (auto& o : out.mc.outputs) o.budget = {o.u};
  return out;
}

}  // namespace km::rotary
