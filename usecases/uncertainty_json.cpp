#include "usecases/uncertainty_json.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <string_view>

namespace km::usecases {
namespace {

nlohmann::json InputsJson(const std::vector<UncertaintyInput>& inputs) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& in : inputs) {
    list.push_back({{"input", in.name}, {"u", in.u}, {"unit", in.unit}, {"stated", in.stated}});
  }
  return list;
}

nlohmann::json NotStated(const std::vector<UncertaintyInput>& inputs) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& in : inputs) {
    if (!in.stated) list.push_back(in.name);
  }
  return list;
}

nlohmann::json FigureJson(const uncertainty::McOutput& out, double k,
                          const std::vector<UncertaintyInput>& inputs) {
  nlohmann::json budget = nlohmann::json::array();
  for (std::size_t i = 0; i < inputs.size() && i < out.budget.size(); ++i) {
    if (!inputs[i].stated) continue;
    budget.push_back({{"input", inputs[i].name},
                      {"u", inputs[i].u},
                      {"unit", inputs[i].unit},
                      {"contribution_um", out.budget[i]}});
  }
  return {{"u_um", out.u},
          {"U_um", out.U},
          {"k", k},
          {"interval_um", {out.low, out.high}},
          {"budget", std::move(budget)}};
}

}  // namespace

std::optional<double> HeaderNumber(const std::map<std::string, std::string>& metadata,
                                   const std::string& key) {
  const auto it = metadata.find(key);
  if (it == metadata.end()) return std::nullopt;
  std::string_view s = it->second;
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);  // the parsers take "+0.35" too
  double v = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) {
    return std::nullopt;
  }
  return v;
}

nlohmann::json UncertaintyJson(const uncertainty::McResult& mc,
                               const std::vector<UncertaintyInput>& inputs,
                               const std::vector<std::string>& figure_keys,
                               const std::vector<uncertainty::GumCheck>& gum) {
  nlohmann::json j = NoUncertaintyJson(inputs);
  j["method"] = "Monte Carlo (JCGM 101)";
  j["draws"] = mc.draws;
  j["seed"] = mc.seed;
  j["k"] = mc.k;
  j["coverage_probability"] = mc.p;
  nlohmann::json figures = nlohmann::json::object();
  nlohmann::json warnings = nlohmann::json::array();
  for (std::size_t i = 0; i < figure_keys.size() && i < mc.outputs.size(); ++i) {
    nlohmann::json f = FigureJson(mc.outputs[i], mc.k, inputs);
    if (i < gum.size()) {
      f["u_gum_um"] = gum[i].u_gum;
      if (gum[i].differs) {
        char text[256];
        std::snprintf(text, sizeof text,
                      "%s: the first-order GUM gives u = %.4g µm, Monte Carlo %.4g µm (%.0f %% "
                      "apart): the figure is not linear in its inputs; the Monte Carlo value is "
                      "reported",
                      figure_keys[i].c_str(), gum[i].u_gum, gum[i].u_mc,
                      100.0 * gum[i].relative_difference);
        warnings.push_back(text);
      }
    }
    figures[figure_keys[i]] = std::move(f);
  }
  j["figures"] = std::move(figures);
  j["warnings"] = std::move(warnings);
  return j;
}

nlohmann::json NoUncertaintyJson(const std::vector<UncertaintyInput>& inputs) {
  return {{"method", "none: no input uncertainty stated"},
          {"inputs", InputsJson(inputs)},
          {"not_stated", NotStated(inputs)},
          {"figures", nlohmann::json::object()},
          {"warnings", nlohmann::json::array()}};
}

}  // namespace km::usecases
