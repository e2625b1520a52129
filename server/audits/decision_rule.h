// Decision rules (ISO 14253-1:2017, [ILAC-G8] §4): how a measured value and its expanded
// uncertainty U are turned into a decision against a limit (a tolerance, or an audit rule's warn
// and stop limits).
//   simple       the value alone: within when value ≤ limit, beyond otherwise ("shared risk",
//                the default, and what the service did before decision rules);
//   guarded      a guard band of w = U on both sides of the limit: within only when
//                value + U ≤ limit, beyond only when value − U > limit, otherwise undecided
//                ("the value is within its uncertainty of the limit");
//   guard_band   the same with a fixed band w = guard_band_pct % of the limit.
// A value whose U is not known (the file stated no input uncertainty) is decided by the value
// alone under every rule, and the decision says so (`u_known` false). Pure: no I/O.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace km::server {

struct DecisionRule {
  enum class Kind { kSimple, kGuarded, kGuardBand } kind = Kind::kSimple;
  double guard_band_pct = 0.0;  // kGuardBand: w in % of the limit, (0, 100]
};

enum class Decision { kWithin, kBeyond, kUndecided };
const char* ToString(Decision d);  // "within", "beyond", "undecided"

struct Judgement {
  Decision decision = Decision::kWithin;
  double guard_band = 0.0;  // w used (same unit as the value)
  bool u_known = false;     // U was known (guarded: w = U)
};

// `value` against `limit` under `rule`; U the value's expanded uncertainty when known.
Judgement Decide(double value, std::optional<double> U, double limit, const DecisionRule& rule);

// The body value of "decision_rule": "simple" | "guarded" | {"rule": "simple" | "guarded" |
// "guard_band", "guard_band_pct": w}. km::InvalidInput naming `field` (or `field`.rule,
// `field`.guard_band_pct). Absent (null): simple.
DecisionRule ParseDecisionRule(const nlohmann::json& value, const std::string& field);
// {"rule": …, "guard_band_pct"?: w, "description": text}.
nlohmann::json DecisionRuleJson(const DecisionRule& rule);
// One line for people: e.g. "guarded acceptance (ISO 14253-1): w = U".
std::string DecisionRuleText(const DecisionRule& rule);

}  // namespace km::server
