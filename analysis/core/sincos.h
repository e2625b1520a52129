// SinCos: sine and cosine of one angle together, for the hot loops of the analyses (the cyclic
// error signatures and their period search evaluate one per sample and period tried). Range
// reduction by multiples of π/2 in three parts (Cody and Waite), then the minimax polynomials
// of fdlibm's sine and cosine kernels on [−π/4, π/4]; within 1 ulp-ish (|error| ≤ 2.3e-16 · max(1,
// |result|) in the tests) of the correctly rounded value for |x| ≤ 1e5 rad. Larger or non-finite
// arguments go to std::sin and std::cos.
#pragma once

#include <cmath>

namespace km {

namespace internal {

// sin(r) and cos(r) for |r| ≤ π/4 (fdlibm __kernel_sin / __kernel_cos coefficients).
inline double KernelSin(double r) {
  const double z = r * r;
  const double p = 8.33333333332248946124e-03 +
                   z * (-1.98412698298579493134e-04 +
                        z * (2.75573137070700676789e-06 +
                             z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)));
  return r + z * r * (-1.66666666666666324348e-01 + z * p);
}

inline double KernelCos(double r) {
  const double z = r * r;
  const double p =
      z * (4.16666666666666019037e-02 +
           z * (-1.38888888888741095749e-03 +
                z * (2.48015872894767294178e-05 +
                     z * (-2.75573143513906633035e-07 +
                          z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  return w + (((1.0 - w) - hz) + z * p);
}

}  // namespace internal

inline void SinCos(double x, double* s, double* c) {
  if (!(std::abs(x) <= 1e5)) {
    *s = std::sin(x);
    *c = std::cos(x);
    return;
  }
  // π/2 in three parts of 33 bits: q · part is exact for |q| < 2²⁰.
  constexpr double kPio2_1 = 1.57079632673412561417e+00;
  constexpr double kPio2_2 = 6.07710050630396597660e-11;
  constexpr double kPio2_3 = 2.02226624871116645580e-21;
  const double q = std::rint(x * 0.63661977236758134308);  // 2/π
  const double r = ((x - q * kPio2_1) - q * kPio2_2) - q * kPio2_3;
  const double sr = internal::KernelSin(r);
  const double cr = internal::KernelCos(r);
  // Quadrant k: (sin, cos) = (sr, cr), (cr, −sr), (−sr, −cr), (−cr, sr) for k = 0 … 3, chosen
  // without a branch (the quadrant of successive samples is not predictable).
  const auto k = static_cast<int>(static_cast<long long>(q) & 3);
  const double v[2] = {sr, cr};
  const double sign[2] = {1.0, -1.0};
  *s = v[k & 1] * sign[k >> 1];
  *c = v[(k & 1) ^ 1] * sign[((k + 1) >> 1) & 1];
}

}  // namespace km
