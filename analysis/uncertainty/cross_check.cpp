#include "analysis/uncertainty/cross_check.h"

#include <cmath>

#include "analysis/core/errors.h"

namespace km::uncertainty {

std::vector<double> FirstOrderUncertainties(const VectorModel& model,
                                            const std::vector<McInput>& inputs,
                                            std::size_t outputs) {
  std::vector<double> x(inputs.size());
  for (std::size_t i = 0; i < inputs.size(); ++i) x[i] = inputs[i].estimate;
  std::vector<double> plus(outputs), minus(outputs), variance(outputs, 0.0);
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const double u = inputs[i].u;
    if (!(u > 0.0)) continue;
    const double h = 1e-3 * u;
    x[i] = inputs[i].estimate + h;
    model(x, plus);
    x[i] = inputs[i].estimate - h;
    model(x, minus);
    x[i] = inputs[i].estimate;
    for (std::size_t j = 0; j < outputs; ++j) {
      const double contribution = (plus[j] - minus[j]) / (2.0 * h) * u;
      variance[j] += contribution * contribution;
    }
  }
  std::vector<double> out(outputs);
  for (std::size_t j = 0; j < outputs; ++j) out[j] = std::sqrt(variance[j]);
  return out;
}

std::vector<GumCheck> CrossCheckGum(const VectorModel& model, const std::vector<McInput>& inputs,
                                    const McResult& mc, const std::vector<std::string>& names,
                                    double tolerance) {
  if (names.size() != mc.outputs.size()) {
    throw InvalidInput("", 0, "names",
                       "names " + std::to_string(names.size()) + " outputs; the result has " +
                           std::to_string(mc.outputs.size()));
  }
  const auto u_gum = FirstOrderUncertainties(model, inputs, mc.outputs.size());
  std::vector<GumCheck> out;
  for (std::size_t j = 0; j < names.size(); ++j) {
    GumCheck c{names[j], u_gum[j], mc.outputs[j].u, 0.0, false};
    const double d = std::abs(c.u_gum - c.u_mc);
    c.relative_difference = c.u_mc > 0.0 ? d / c.u_mc : (d > 0.0 ? HUGE_VAL : 0.0);
    c.differs = c.relative_difference > tolerance;
    out.push_back(c);
  }
  return out;
}

}  // namespace km::uncertainty
