// The first-order GUM propagation ([JCGM 100] §5.1, eq. (10)) of every output of a model, beside
// its Monte Carlo propagation ([JCGM 101] §8, "validation of the GUM uncertainty framework"): a
// figure whose two standard uncertainties differ by more than a tolerance (5 % by default) is
// marked, as for a nonlinear figure such as a range whose extremes move with the inputs.
#pragma once

#include <string>
#include <vector>

#include "analysis/uncertainty/monte_carlo.h"

namespace km::uncertainty {

struct GumCheck {
  std::string name;
  double u_gum = 0.0;                // first-order law of propagation, uncorrelated inputs
  double u_mc = 0.0;                 // the Monte Carlo result's u
  double relative_difference = 0.0;  // |u_gum − u_mc| / u_mc (0 when both are 0)
  bool differs = false;              // relative_difference > tolerance
};

// The first-order standard uncertainty of each output of `model` at the inputs' estimates:
// sensitivities by central differences of ±1e-3·u_i, combined as √Σ(c_ij·u_i)².
std::vector<double> FirstOrderUncertainties(const VectorModel& model,
                                            const std::vector<McInput>& inputs,
                                            std::size_t outputs);

// Each output's first-order u beside the Monte Carlo result of the same model and inputs;
// `names` names the outputs (as many as mc.outputs).
std::vector<GumCheck> CrossCheckGum(const VectorModel& model, const std::vector<McInput>& inputs,
                                    const McResult& mc, const std::vector<std::string>& names,
                                    double tolerance = 0.05);

}  // namespace km::uncertainty
