// The uncertainty of every ISO 230-2 and VDI/DGQ 3441 figure of a laser positioning test,
// propagated by Monte Carlo ([JCGM 101] §7) through the figure code itself
// (docs/methods.md §16.3).
//
// Inputs (standard uncertainties, k = 1, normal; each acts on every reading together, one draw
// per trial): the laser's relative reading error ε (u_laser_ppm), the air temperature, pressure
// and humidity the refractive index was computed from (raw readings only), the machine
// temperature and the expansion coefficient of the correction to 20 °C. With d = (P − datum)·1000
// the distance from the datum in µm and x the raw reading's deviation, one draw of the inputs
// turns each reading into
//   x' = (d + x)·(1 + ε)/n(T_air, p, RH) − d − α·(T − 20 °C)·d·10⁻⁶,
// an affine map x' = c·x + o_i whose scale c is the same at every target. So the per-target
// figures transform exactly — x̄' = c·x̄ + o_i, s' = |c|·s, B_i' = c·B_i, R_i' = |c|·R_i — and each
// draw evaluates the axis figures with the product's own AxisFigures and VdiFigures
// (analysis/positioning/figures.h) over the transformed targets: O(targets) per draw, whatever
// the number of readings. The machine's own scatter (s, R, the ±2s bands) is what the figures
// describe; it is not an input. A pure numerical module: no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/positioning/air.h"
#include "analysis/positioning/figures.h"
#include "analysis/uncertainty/cross_check.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace km::positioning {

// Standard uncertainties (k = 1) of the inputs; 0: not stated.
struct PositioningInputUncertainties {
  double laser_ppm = 0.0;               // relative, of the laser's reading
  double air_temperature_c = 0.0;       // raw readings only (settings.air set)
  double air_pressure_pa = 0.0;         // raw readings only
  double air_humidity_pct = 0.0;        // raw readings only
  double material_temperature_c = 0.0;  // with the material correction only
  double expansion_ppm_per_k = 0.0;     // with the material correction only

  bool Any() const;
};

// The inputs in the order the propagation draws them (and its budget lists them): the header
// keys u_laser_ppm, u_air_temperature_c, u_air_pressure_pa, u_air_humidity_pct,
// u_material_temperature_c, u_expansion_ppm_per_k.
inline constexpr std::size_t kPositioningInputs = 6;
const std::vector<std::string>& PositioningInputNames();

// The figures propagated, by their key in the result (docs/formats.md §3.14): the twelve ISO
// 230-2 figures, then vdi3441.P_um, vdi3441.Ps_um, vdi3441.U_um, vdi3441.Pa_um.
const std::vector<std::string>& PositioningFigureKeys();

// Monte Carlo size: M draws of all inputs together, the budget with budget_draws per stated
// input. M = 15 000 leaves the statistical error of u near 1/√(2M) = 0.6 %, a budget row's
// 1/√(2·2 500) = 1.4 %; with all six inputs stated, 30 000 evaluations of the figures.
inline constexpr std::size_t kPositioningDraws = 15'000;
inline constexpr std::size_t kPositioningBudgetDraws = 2'500;
inline constexpr std::uint64_t kPositioningSeed = 20230;

struct PositioningUncertainty {
  uncertainty::McResult mc;                // outputs in the order of PositioningFigureKeys()
  std::vector<uncertainty::GumCheck> gum;  // first-order GUM beside it
};

// The model of one draw, as McInputs and a VectorModel over PositioningFigureKeys(); `raw`
// holds the per-target figures of the uncorrected readings (EvaluatePositioning of the file's
// readings), `settings` the corrections the analysis applied.
std::vector<uncertainty::McInput> PositioningMcInputs(const CorrectionSettings& settings,
                                                      const PositioningInputUncertainties& u);
uncertainty::VectorModel PositioningModel(const std::vector<TargetFigures>& raw,
                                          const CorrectionSettings& settings);

// The propagation (seeded, fixed M; options.draws etc. as given) and its GUM check (5 %). A
// figure whose draws differ by rounding alone (u below 10⁻¹⁰ of the figure) gets u = 0.
PositioningUncertainty PropagatePositioningUncertainty(const std::vector<TargetFigures>& raw,
                                                       const CorrectionSettings& settings,
                                                       const PositioningInputUncertainties& u,
                                                       const uncertainty::McOptions& options);
// The same with kPositioningDraws, kPositioningBudgetDraws and kPositioningSeed.
PositioningUncertainty PropagatePositioningUncertainty(const std::vector<TargetFigures>& raw,
                                                       const CorrectionSettings& settings,
                                                       const PositioningInputUncertainties& u);

}  // namespace km::positioning
