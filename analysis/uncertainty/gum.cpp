#include "analysis/uncertainty/gum.h"

#include <cmath>

#include "analysis/core/errors.h"
#include "analysis/core/statistics.h"

namespace km::uncertainty {
namespace {

void CheckSameSize(std::size_t a, std::size_t b, const char* field) {
  if (a != b) throw InvalidInput("", 0, field, "sizes differ");
}

void CheckUncertainties(const std::vector<double>& u) {
  for (double ui : u) {
    if (!(ui >= 0.0 && std::isfinite(ui))) {
      throw InvalidInput("", 0, "u", "a standard uncertainty must be finite and not negative");
    }
  }
}

void CheckLevel(double p) {
  if (!(p > 0.0 && p < 1.0)) throw InvalidInput("", 0, "p", "must be within (0, 1)");
}

void CheckCorrelation(const Eigen::MatrixXd& r, std::size_t n) {
  if (r.rows() != static_cast<Eigen::Index>(n) || r.cols() != static_cast<Eigen::Index>(n)) {
    throw InvalidInput("", 0, "correlation", "must be N × N");
  }
  for (Eigen::Index i = 0; i < r.rows(); ++i) {
    if (std::abs(r(i, i) - 1.0) > 1e-12) {
      throw InvalidInput("", 0, "correlation", "the diagonal must be 1");
    }
    for (Eigen::Index j = 0; j < i; ++j) {
      if (std::abs(r(i, j) - r(j, i)) > 1e-12 || std::abs(r(i, j)) > 1.0) {
        throw InvalidInput("", 0, "correlation", "must be symmetric with |r_ij| ≤ 1");
      }
    }
  }
}

// Smallest x in [lo, hi] with g(x) ≥ target for an increasing g, by bisection to the last bit.
template <typename G>
double BisectIncreasing(const G& g, double target, double lo, double hi) {
  for (int i = 0; i < 200 && hi - lo > 0.0; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (g(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::vector<double> Estimates(const std::vector<GumInput>& inputs) {
  std::vector<double> x;
  x.reserve(inputs.size());
  for (const auto& in : inputs) x.push_back(in.estimate);
  return x;
}

std::vector<double> Uncertainties(const std::vector<GumInput>& inputs) {
  std::vector<double> u;
  u.reserve(inputs.size());
  for (const auto& in : inputs) u.push_back(in.u);
  return u;
}

// The budget rows and ν_eff, k, U of a result whose y and u_c are set.
void FinishResult(const std::vector<GumInput>& inputs, const std::vector<double>& c,
                  GumResult& out) {
  std::vector<double> contributions;
  std::vector<double> dof;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const double ci = c[i] * inputs[i].u;
    out.budget.push_back({inputs[i].name, inputs[i].u, c[i], ci, inputs[i].dof});
    contributions.push_back(ci);
    dof.push_back(inputs[i].dof);
  }
  out.nu_eff = WelchSatterthwaite(out.u_c, contributions, dof);
  out.k = CoverageFactor(out.nu_eff, out.p);
  out.U = out.k * out.u_c;
}

}  // namespace

std::vector<double> SensitivityCoefficients(const ScalarModel& f, const std::vector<double>& x,
                                            const std::vector<double>& u, double relative_step) {
  CheckSameSize(x.size(), u.size(), "u");
  CheckUncertainties(u);
  if (!(relative_step > 0.0)) throw InvalidInput("", 0, "relative_step", "must be positive");
  std::vector<double> c(x.size(), 0.0);
  std::vector<double> xs = x;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double h = relative_step * (u[i] > 0.0 ? u[i] : std::max(std::abs(x[i]), 1.0));
    xs[i] = x[i] + h;
    const double up = f(xs);
    xs[i] = x[i] - h;
    const double down = f(xs);
    xs[i] = x[i];
    c[i] = (up - down) / (2.0 * h);
  }
  return c;
}

double CombinedStandardUncertainty(const std::vector<double>& c, const std::vector<double>& u) {
  CheckSameSize(c.size(), u.size(), "u");
  CheckUncertainties(u);
  double sum = 0.0;
  for (std::size_t i = 0; i < c.size(); ++i) sum += (c[i] * u[i]) * (c[i] * u[i]);
  return std::sqrt(sum);
}

double CombinedStandardUncertainty(const std::vector<double>& c, const std::vector<double>& u,
                                   const Eigen::MatrixXd& r) {
  CheckSameSize(c.size(), u.size(), "u");
  CheckUncertainties(u);
  CheckCorrelation(r, c.size());
  Eigen::VectorXd cu(static_cast<Eigen::Index>(c.size()));
  for (std::size_t i = 0; i < c.size(); ++i) cu(static_cast<Eigen::Index>(i)) = c[i] * u[i];
  // A correlation matrix is positive semi-definite; rounding may leave a tiny negative sum.
  return std::sqrt(std::max(0.0, cu.dot(r * cu)));
}

double WelchSatterthwaite(double u_c, const std::vector<double>& contributions,
                          const std::vector<double>& dof) {
  CheckSameSize(contributions.size(), dof.size(), "dof");
  double denominator = 0.0;
  for (std::size_t i = 0; i < dof.size(); ++i) {
    if (!(dof[i] > 0.0)) throw InvalidInput("", 0, "dof", "degrees of freedom must be positive");
    if (std::isinf(dof[i])) continue;
    const double c2 = contributions[i] * contributions[i];
    denominator += c2 * c2 / dof[i];
  }
  if (denominator <= 0.0 || u_c <= 0.0) return kInfiniteDof;
  const double u2 = u_c * u_c;
  return u2 * u2 / denominator;
}

double TwoSidedNormalQuantile(double p) {
  CheckLevel(p);
  // P(|Z| ≤ z) = erf(z/√2), increasing in z.
  const auto coverage = [](double z) { return std::erf(z / std::sqrt(2.0)); };
  return BisectIncreasing(coverage, p, 0.0, 40.0);
}

double TwoSidedTQuantile(double p, double nu) {
  CheckLevel(p);
  if (!(nu > 0.0)) throw InvalidInput("", 0, "nu", "degrees of freedom must be positive");
  if (std::isinf(nu) || nu > 1e10) return TwoSidedNormalQuantile(p);
  // P(|T| > t) = I_x(ν/2, 1/2) with x = ν/(ν + t²): I_x increases with x, so solve
  // I_x = 1 − p for x, then t = √(ν (1 − x) / x).
  const auto tail = [nu](double x) { return RegularisedIncompleteBeta(0.5 * nu, 0.5, x); };
  const double x = BisectIncreasing(tail, 1.0 - p, 0.0, 1.0);
  return std::sqrt(nu * (1.0 - x) / x);
}

double CoverageFactor(double nu_eff, double p) {
  if (std::isinf(nu_eff)) return TwoSidedNormalQuantile(p);
  if (!(nu_eff >= 1.0)) throw InvalidInput("", 0, "nu_eff", "must be at least 1");
  return TwoSidedTQuantile(p, std::floor(nu_eff));
}

GumResult PropagateGum(const std::vector<GumInput>& inputs, const std::vector<double>& c, double y,
                       double p) {
  CheckLevel(p);
  CheckSameSize(inputs.size(), c.size(), "sensitivity");
  GumResult out;
  out.y = y;
  out.p = p;
  out.u_c = CombinedStandardUncertainty(c, Uncertainties(inputs));
  FinishResult(inputs, c, out);
  return out;
}

GumResult PropagateGum(const ScalarModel& f, const std::vector<GumInput>& inputs, double p) {
  const auto x = Estimates(inputs);
  const auto c = SensitivityCoefficients(f, x, Uncertainties(inputs));
  return PropagateGum(inputs, c, f(x), p);
}

GumResult PropagateGumCorrelated(const ScalarModel& f, const std::vector<GumInput>& inputs,
                                 const Eigen::MatrixXd& r, double p) {
  CheckLevel(p);
  const auto x = Estimates(inputs);
  const auto u = Uncertainties(inputs);
  const auto c = SensitivityCoefficients(f, x, u);
  GumResult out;
  out.y = f(x);
  out.p = p;
  out.u_c = CombinedStandardUncertainty(c, u, r);
  FinishResult(inputs, c, out);
  return out;
}

}  // namespace km::uncertainty
