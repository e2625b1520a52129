#include "analysis/positioning/air.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "analysis/core/errors.h"

namespace km::positioning {
namespace {

void CheckRange(double value, double lo, double hi, const char* field, const char* unit) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    throw InvalidInput("", 0, field,
                       std::to_string(value) + " " + unit + " is outside " + std::to_string(lo) +
                           " … " + std::to_string(hi) + " " + unit +
                           ", the range of the refractive-index equation (Birch & Downs)");
  }
}

}  // namespace

double SaturationVapourPressurePa(double temperature_c) {
  // IAPWS-IF97 saturation-pressure equation (region 4), coefficients n1 … n10.
  constexpr double k1 = 1.16705214528e+03, k2 = -7.24213167032e+05, k3 = -1.70738469401e+01;
  constexpr double k4 = 1.20208247025e+04, k5 = -3.23255503223e+06, k6 = 1.49151086135e+01;
  constexpr double k7 = -4.82326573616e+03, k8 = 4.05113405421e+05, k9 = -2.38555575678e-01;
  constexpr double k10 = 6.50175348448e+02;
  const double t_k = temperature_c + 273.15;
  const double omega = t_k + k9 / (t_k - k10);
  const double a = omega * omega + k1 * omega + k2;
  const double b = k3 * omega * omega + k4 * omega + k5;
  const double c = k6 * omega * omega + k7 * omega + k8;
  const double x = -b + std::sqrt(b * b - 4.0 * a * c);
  return 1e6 * std::pow(2.0 * c / x, 4);
}

void CheckAirConditions(const AirConditions& air) {
  CheckRange(air.temperature_c, 0.0, 100.0, "air_temperature_c", "°C");
  CheckRange(air.pressure_pa, 10000.0, 140000.0, "air_pressure_pa", "Pa");
  CheckRange(air.humidity_pct, 0.0, 100.0, "air_humidity_pct", "%");
  CheckRange(air.wavelength_nm, 300.0, 1700.0, "laser_wavelength_nm", "nm");
}

double RefractiveIndexOfAir(const AirConditions& air) {
  CheckAirConditions(air);
  const double lambda_um = air.wavelength_nm * 1e-3;
  const double s = 1.0 / (lambda_um * lambda_um);
  const double t = air.temperature_c;
  const double p = air.pressure_pa;
  const double ns_minus_1 = 1e-8 * (8342.54 + 2406147.0 / (130.0 - s) + 15998.0 / (38.9 - s));
  const double x = (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.003661 * t);
  const double ntp = 1.0 + p * ns_minus_1 * x / 96095.43;
  const double pv = air.humidity_pct / 100.0 * SaturationVapourPressurePa(t);
  return ntp - 1e-10 * (292.75 / (t + 273.15)) * (3.7345 - 0.0401 * s) * pv;
}

double ThermalExpansionUm(double expansion_ppm_per_k, double temperature_c, double position_mm,
                          double datum_mm) {
  // ppm/K · K · mm = 1e-6 mm = 1e-3 µm.
  return expansion_ppm_per_k * (temperature_c - 20.0) * (position_mm - datum_mm) * 1e-3;
}

namespace {

double AirCorrectionUm(double n, double target_mm, double datum_mm, double deviation_um) {
  return deviation_um / n + (target_mm - datum_mm) * (1.0 / n - 1.0) * 1000.0 - deviation_um;
}

}  // namespace

std::vector<Reading> ApplyCorrections(std::vector<Reading> readings,
                                      const CorrectionSettings& settings,
                                      AppliedCorrections& applied) {
  applied = AppliedCorrections{};
  const double datum = settings.datum_mm;
  for (const Reading& r : readings) {
    if (std::abs(r.target_mm - datum) > std::abs(applied.end_of_axis_mm - datum) ||
        &r == &readings.front()) {
      applied.end_of_axis_mm = r.target_mm;
    }
  }
  if (settings.air) {
    applied.air_applied = true;
    applied.air = *settings.air;
    applied.refractive_index = RefractiveIndexOfAir(*settings.air);
    const double n = applied.refractive_index;
    for (Reading& r : readings)
      r.deviation_um += AirCorrectionUm(n, r.target_mm, datum, r.deviation_um);
    applied.air_correction_at_end_um = AirCorrectionUm(n, applied.end_of_axis_mm, datum, 0.0);
  }
  if (settings.material_temperature_c) {
    applied.material_applied = true;
    applied.material_temperature_c = *settings.material_temperature_c;
    applied.expansion_ppm_per_k = settings.expansion_ppm_per_k;
    const double t = *settings.material_temperature_c;
    const double a = settings.expansion_ppm_per_k;
    for (Reading& r : readings) r.deviation_um -= ThermalExpansionUm(a, t, r.target_mm, datum);
    applied.material_correction_at_end_um =
        -ThermalExpansionUm(a, t, applied.end_of_axis_mm, datum);
  }
  return readings;
}

}  // namespace km::positioning
