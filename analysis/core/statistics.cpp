#include "analysis/core/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/core/errors.h"

namespace km {
namespace {

// Continued fraction of I_x(a, b) (modified Lentz), valid and fast for x < (a + 1)/(a + b + 2).
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  constexpr double kEps = 1e-15;
  constexpr int kMaxIter = 100000;
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0;
  double d = 1.0 - qab * x / qap;
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= kMaxIter; ++m) {
    const double m2 = 2.0 * m;
    // Even term d_2m = m (b − m) x / ((a + 2m − 1)(a + 2m)).
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    // Odd term d_2m+1 = −(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < kEps) return h;
  }
  throw DidNotConverge("incomplete beta continued fraction did not converge");
}

// log of x^a (1 − x)^b / B(a, b), with 1 − x given separately (no cancellation).
double LogBetaFront(double a, double b, double x, double one_minus_x) {
  return std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
         b * std::log(one_minus_x);
}

// Robust σ of pooled successive differences: 1.4826 · MAD / √2.
double MadSigma(std::vector<double> d) {
  if (d.empty()) return 0.0;
  auto median = [](std::vector<double>& v) {
    const std::size_t h = v.size() / 2;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h), v.end());
    double m = v[h];
    if (v.size() % 2 == 0) {
      m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(h)));
    }
    return m;
  };
  const double med = median(d);
  for (double& x : d) x = std::abs(x - med);
  return 1.4826 * median(d) / std::numbers::sqrt2;
}

}  // namespace

double RegularisedIncompleteBeta(double a, double b, double x) {
  if (!(a > 0.0 && b > 0.0)) throw InvalidInput("", 0, "a, b", "must be positive");
  if (!(x >= 0.0 && x <= 1.0)) throw InvalidInput("", 0, "x", "must be within [0, 1]");
  if (x == 0.0) return 0.0;
  if (x == 1.0) return 1.0;
  const double front = std::exp(LogBetaFront(a, b, x, 1.0 - x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - front * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

double LogFUpperTail(double f, double d1, double d2) {
  if (!(d1 > 0.0 && d2 > 0.0)) throw InvalidInput("", 0, "degrees of freedom", "must be > 0");
  if (!(f > 0.0)) return 0.0;  // P = 1
  if (std::isinf(f)) return -std::numeric_limits<double>::infinity();
  // P(F > f) = I_x(d2/2, d1/2), x = d2 / (d2 + d1 f); 1 − x computed without cancellation.
  const double a = 0.5 * d2, b = 0.5 * d1;
  const double x = d2 / (d2 + d1 * f);
  const double one_minus_x = d1 * f / (d2 + d1 * f);
  const double log_front = LogBetaFront(a, b, x, one_minus_x);
  if (x < (a + 1.0) / (a + b + 2.0)) {
    // Direct branch, in logs so that tiny p-values do not underflow.
    return log_front + std::log(BetaContinuedFraction(a, b, x)) - std::log(a);
  }
  const double q = std::exp(log_front) * BetaContinuedFraction(b, a, one_minus_x) / b;
  return std::log1p(-std::min(q, 1.0));
}

double RobustDiffNoiseUm(const std::vector<std::vector<double>>& residual_per_trace) {
  std::vector<double> d;
  for (const auto& r : residual_per_trace)
    for (std::size_t i = 1; i < r.size(); ++i) d.push_back(r[i] - r[i - 1]);
  return MadSigma(std::move(d));
}

}  // namespace km
