// Harmonic content of a radial-error trace r(θ) sampled at arbitrary (possibly non-uniform)
// angles over one turn. Convention:
//
//   r(θ) ≈ a_0 + Σ_{k=1..N} a_k cos(k θ − φ_k),   a_k ≥ 0 (µm),  φ_k ∈ [0°, 360°)
//
// θ is the commanded angle from the first plane axis towards the second. The coefficients
// C_k = a_k cos φ_k, S_k = a_k sin φ_k of the basis {1, cos kθ, sin kθ} are found by linear
// least squares (normal equations, LDLᵀ), which is exact for non-uniform spacing; for uniform
// spacing over a full turn it coincides with the discrete Fourier transform.
#pragma once

#include <vector>

namespace km::dbb {

struct Harmonic {
  int order = 0;
  double amplitude_um = 0.0;
  double phase_deg = 0.0;
  double cos_um = 0.0;  // C_k
  double sin_um = 0.0;  // S_k
};

struct HarmonicsResult {
  double mean_um = 0.0;             // a_0
  std::vector<Harmonic> harmonics;  // orders 1…N
  double residual_rms_um = 0.0;
};

// Throws km::InvalidInput when there are fewer than 2N + 1 samples or the sizes differ.
HarmonicsResult FitHarmonics(const std::vector<double>& angle_rad, const std::vector<double>& r_um,
                             int max_order);
// Same, from cos θ and sin θ of the samples (no trigonometry of its own).
HarmonicsResult FitHarmonics(const std::vector<double>& cos_angle,
                             const std::vector<double>& sin_angle, const std::vector<double>& r_um,
                             int max_order);

}  // namespace km::dbb
