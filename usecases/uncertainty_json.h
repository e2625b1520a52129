// The `uncertainty` object of a result (docs/formats.md §3.17): what a Monte Carlo propagation
// ([JCGM 101]) of a measurement's stated input uncertainties through its analysis gives for each
// figure, with the first-order GUM propagation ([JCGM 100] §5.1) beside it as a check. Shared by
// every kind whose file states `u_*` keys (positioning, DBB, form), so they all read alike:
//   {"method", "draws", "seed", "k", "coverage_probability",
//    "inputs": [{"input", "u", "unit", "stated"}],      every input the kind knows
//    "not_stated": [input, …],                             those the file did not state (u = 0)
//    "figures": {KEY: {"u_um", "U_um", "k", "interval_um": [low, high], "u_gum_um",
//                      "budget": [{"input", "u", "unit", "contribution_um"}]}},
//    "warnings": [text, …]}                                GUM and Monte Carlo differ by > 5 %
// Also the reading of the `u_*` header keys, which the parsers have already checked (a finite
// number ≥ 0, ingest/text_format.h).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/uncertainty/cross_check.h"
#include "analysis/uncertainty/monte_carlo.h"

namespace km::usecases {

// One input of a kind's uncertainty model, as the file (or the instrument register) states it.
struct UncertaintyInput {
  std::string name;  // the header key, e.g. "u_laser_ppm"
  double u = 0.0;    // standard uncertainty (k = 1) in `unit`; 0 when not stated
  std::string unit;  // "ppm", "°C", "Pa", "%", "ppm/K", "µm"
  bool stated = false;
};

// The header key `key` of `metadata` as a number, when the file states it.
std::optional<double> HeaderNumber(const std::map<std::string, std::string>& metadata,
                                   const std::string& key);

// `inputs` names the inputs in the order of the McInputs the propagation drew (the budget of
// mc.outputs[i] has one entry per input); `figure_keys` names mc's outputs in order; `gum` the
// cross-check of the same outputs (may be empty: no check).
nlohmann::json UncertaintyJson(const uncertainty::McResult& mc,
                               const std::vector<UncertaintyInput>& inputs,
                               const std::vector<std::string>& figure_keys,
                               const std::vector<uncertainty::GumCheck>& gum);

// The `uncertainty` object of a result whose file states no input uncertainty: the inputs, all
// "not stated", and no figures (nothing to propagate).
nlohmann::json NoUncertaintyJson(const std::vector<UncertaintyInput>& inputs);

}  // namespace km::usecases
