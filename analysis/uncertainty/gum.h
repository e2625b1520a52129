// First-order propagation of standard uncertainties, the law of propagation of uncertainty
// ([JCGM 100] §5): the combined standard uncertainty u_c(y) of y = f(x_1 … x_N) from the
// sensitivity coefficients c_i = ∂f/∂x_i at the estimates (given, or by central finite
// differences) and the standard uncertainties u(x_i), for uncorrelated inputs (§5.1) or with a
// correlation matrix r (§5.2); each input's contribution c_i·u(x_i) (the budget); the effective
// degrees of freedom by the Welch–Satterthwaite formula (eq. G.2b) and the coverage factor
// k = t_p(ν_eff) of the t-distribution (G.6.2, G.6.4). A pure numerical module: no I/O.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace km::uncertainty {

// Degrees of freedom of a standard uncertainty taken as known exactly: it adds nothing to the
// denominator of [JCGM 100] eq. G.2b.
inline constexpr double kInfiniteDof = std::numeric_limits<double>::infinity();

// One input quantity: its estimate x_i, standard uncertainty u(x_i) (k = 1) and the degrees of
// freedom ν_i of u(x_i).
struct GumInput {
  std::string name;
  double estimate = 0.0;
  double u = 0.0;
  double dof = kInfiniteDof;
};

// One row of the budget: u(x_i), c_i, the contribution u_i(y) = c_i·u(x_i) (signed; its square
// is the input's share of u_c² when the inputs are uncorrelated) and ν_i.
struct GumBudgetRow {
  std::string name;
  double u = 0.0;
  double sensitivity = 0.0;
  double contribution = 0.0;
  double dof = kInfiniteDof;
};

struct GumResult {
  double y = 0.0;       // f at the estimates
  double u_c = 0.0;     // combined standard uncertainty
  double nu_eff = 0.0;  // effective degrees of freedom (eq. G.2b), may be infinite
  double p = 0.95;      // level of confidence of the expanded uncertainty
  double k = 0.0;       // coverage factor t_p(ν_eff), ν_eff truncated to an integer (G.6.4)
  double U = 0.0;       // expanded uncertainty k·u_c
  std::vector<GumBudgetRow> budget;
};

// A scalar measurement model y = f(x).
using ScalarModel = std::function<double(const std::vector<double>&)>;

// c_i = ∂f/∂x_i at x by central differences (f(x + h e_i) − f(x − h e_i)) / 2h, with
// h = relative_step·u_i, or relative_step·max(|x_i|, 1) where u_i = 0. Exact up to rounding for
// a model linear in x_i; 2N evaluations of f.
std::vector<double> SensitivityCoefficients(const ScalarModel& f, const std::vector<double>& x,
                                            const std::vector<double>& u,
                                            double relative_step = 1e-3);

// u_c = √(Σ (c_i u_i)²), [JCGM 100] §5.1 (uncorrelated inputs).
double CombinedStandardUncertainty(const std::vector<double>& c, const std::vector<double>& u);
// u_c = √(Σ_i Σ_j c_i c_j u_i u_j r_ij), [JCGM 100] §5.2; r symmetric with unit diagonal and
// |r_ij| ≤ 1.
double CombinedStandardUncertainty(const std::vector<double>& c, const std::vector<double>& u,
                                   const Eigen::MatrixXd& r);

// ν_eff = u_c⁴ / Σ (u_i(y)⁴ / ν_i), [JCGM 100] eq. G.2b, over the contributions u_i(y) = c_i u_i;
// inputs of infinite ν_i add nothing; infinite when every term is zero.
double WelchSatterthwaite(double u_c, const std::vector<double>& contributions,
                          const std::vector<double>& dof);

// Two-sided quantile t_p(ν) of the t-distribution: P(|T_ν| ≤ t_p) = p, for real ν > 0; the
// normal quantile for infinite ν. Bisection on the regularised
// incomplete beta function, P(|T_ν| > t) = I_{ν/(ν+t²)}(ν/2, 1/2).
double TwoSidedTQuantile(double p, double nu);
// Two-sided normal quantile z_p: P(|Z| ≤ z_p) = p.
double TwoSidedNormalQuantile(double p);
// k_p = t_p(ν) with ν truncated to the next lower integer ([JCGM 100] G.6.4), ν ≥ 1.
double CoverageFactor(double nu_eff, double p);

// The whole evaluation with the given sensitivity coefficients c and value y (§5.1, G.2b).
GumResult PropagateGum(const std::vector<GumInput>& inputs, const std::vector<double>& c, double y,
                       double p = 0.95);
// Sensitivity coefficients by central differences of f (SensitivityCoefficients).
GumResult PropagateGum(const ScalarModel& f, const std::vector<GumInput>& inputs, double p = 0.95);
// Correlated inputs (§5.2). Eq. G.2b assumes independent inputs; here it is applied to the
// contributions with the correlated u_c, an approximation the caller should state.
GumResult PropagateGumCorrelated(const ScalarModel& f, const std::vector<GumInput>& inputs,
                                 const Eigen::MatrixXd& r, double p = 0.95);

}  // namespace km::uncertainty
