// Distributions and robust scales used by the discovery engine's tests (analysis/discovery):
// the F-distribution's upper tail through the regularised incomplete beta function, and the
// robust white-noise σ of a residual from its successive differences.
//
// Noise floor: for white noise of σ the successive differences Δ of one trace are N(0, 2σ²);
// σ = 1.4826 · MAD(Δ) / √2. Smooth unmodelled errors change Δ by (slope × sample spacing),
// negligible at DBB sampling, and the few large differences at steps (backlash) or spikes do
// not move a median — so the floor is what no smooth model can explain.
#pragma once

#include <vector>

namespace km {

// Regularised incomplete beta function I_x(a, b), a, b > 0, 0 ≤ x ≤ 1 (continued fraction,
// modified Lentz; symmetry I_x(a, b) = 1 − I_{1−x}(b, a) where it converges faster).
double RegularisedIncompleteBeta(double a, double b, double x);
// Natural log of the upper tail P(F_{d1,d2} > f) = I_{d2/(d2 + d1 f)}(d2/2, d1/2); finite also
// where the tail underflows a double.
double LogFUpperTail(double f, double d1, double d2);
// Robust white-noise σ of residuals, one vector per trace: 1.4826 · MAD(Δ) / √2 of the pooled
// successive differences inside each trace.
double RobustDiffNoiseUm(const std::vector<std::vector<double>>& residual_per_trace);

}  // namespace km
