// Refractive index of air and the corrections a laser positioning measurement needs
// (docs/methods.md §15.1, §15.2).
//
// Refractive index: the updated Edlén equation of [Birch & Downs 1993] with the corrected
// dispersion constants of [Birch & Downs 1994], in the form written out by [NIST refractive index]
// appendix A-IV ("modified Edlén"), whose water-vapour term carries the factor 292.75 / T:
//   σ² = 1 / λ²                                   (λ vacuum wavelength in µm)
//   (n_s − 1)·10⁸ = 8342.54 + 2406147 / (130 − σ²) + 15998 / (38.9 − σ²)
//                                                  (dry air, 15 °C, 101 325 Pa, 450 ppm CO₂)
//   X = (1 + 10⁻⁸·(0.601 − 0.00972·t)·p) / (1 + 0.003661·t)
//   n_tp = 1 + p·(n_s − 1)·X / 96095.43
//   n = n_tp − 10⁻¹⁰·(292.75 / T)·(3.7345 − 0.0401·σ²)·p_v
// with t in °C, T = t + 273.15 K, p in Pa and p_v the partial pressure of water vapour from the
// relative humidity: p_v = (RH / 100)·p_sv(t), p_sv the saturation vapour pressure over water of
// the IAPWS-IF97 formula ([NIST refractive index] A-I, A-II). CO₂ is taken as 450 ppm, the
// reference content of the equation (no CO₂ term).
//
// Range: inputs are refused (km::InvalidInput naming the field) outside the range over which
// [NIST refractive index] states the calculation valid (§VI, input limits of the calculator),
// restricted to air above 0 °C (the saturation pressure over water): air temperature 0 … 100 °C,
// pressure 10 000 … 140 000 Pa, relative humidity 0 … 100 %, vacuum wavelength 300 … 1700 nm.
// Its stated uncertainty (about 2·10⁻⁸) holds within 0 … 40 °C and 60 000 … 120 000 Pa.
#pragma once

#include <optional>
#include <vector>

#include "analysis/positioning/figures.h"

namespace km::positioning {

struct AirConditions {
  double temperature_c = 20.0;
  double pressure_pa = 101325.0;
  double humidity_pct = 50.0;
  double wavelength_nm = 632.990;  // vacuum wavelength of a He-Ne laser
};

// Saturation vapour pressure over water (Pa), IAPWS-IF97 ([NIST refractive index] A-I).
double SaturationVapourPressurePa(double temperature_c);

// n of moist air. Throws km::InvalidInput (field `air_temperature_c`, `air_pressure_pa`,
// `air_humidity_pct` or `laser_wavelength_nm`) for an input outside the range above.
double RefractiveIndexOfAir(const AirConditions& air);

// Checks the range alone (the same errors as RefractiveIndexOfAir).
void CheckAirConditions(const AirConditions& air);

// Material correction to 20 °C in µm (docs/methods.md §15.2): the deviation at a target P_mm of an
// axis whose scale and part were at temperature_c, with expansion coefficient α (ppm/K), is
// x₂₀ = x − α·(T − 20 °C)·(P − datum); this returns the term subtracted, α·(T − 20)·(P − datum)
// in µm.
double ThermalExpansionUm(double expansion_ppm_per_k, double temperature_c, double position_mm,
                          double datum_mm);

// What a file asks to be corrected (docs/methods.md §15.1, §15.2).
struct CorrectionSettings {
  double datum_mm = 0.0;             // where the laser was zeroed
  std::optional<AirConditions> air;  // set: the readings were taken with n = 1
  std::optional<double> material_temperature_c;
  double expansion_ppm_per_k = 0.0;  // with material_temperature_c
};

// What was applied, and its size at the end of the axis: the target farthest from the datum.
struct AppliedCorrections {
  bool air_applied = false;
  AirConditions air;
  double refractive_index = 1.0;  // n (1 when not applied)
  bool material_applied = false;
  double material_temperature_c = 20.0;
  double expansion_ppm_per_k = 0.0;
  double end_of_axis_mm = 0.0;
  double air_correction_at_end_um = 0.0;       // added to the deviation there
  double material_correction_at_end_um = 0.0;  // added to the deviation there
};

// Corrects readings whose deviation_um is the raw laser reading minus the target:
//   air:      x ← x/n + (P − datum)·(1/n − 1)·1000   (the distance from the datum divided by n)
//   material: x ← x − α·(T − 20 °C)·(P − datum)
// Throws km::InvalidInput for air conditions outside the range of RefractiveIndexOfAir.
std::vector<Reading> ApplyCorrections(std::vector<Reading> readings,
                                      const CorrectionSettings& settings,
                                      AppliedCorrections& applied);

}  // namespace km::positioning
