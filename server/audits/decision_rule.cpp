#include "server/audits/decision_rule.h"

#include <cmath>
#include <cstdio>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

const char* RuleName(DecisionRule::Kind k) {
  switch (k) {
    case DecisionRule::Kind::kSimple:
      return "simple";
    case DecisionRule::Kind::kGuarded:
      return "guarded";
    case DecisionRule::Kind::kGuardBand:
      return "guard_band";
  }
  return "simple";
}

DecisionRule::Kind RuleKind(const std::string& name, const std::string& field) {
  if (name == "simple") return DecisionRule::Kind::kSimple;
  if (name == "guarded") return DecisionRule::Kind::kGuarded;
  if (name == "guard_band") return DecisionRule::Kind::kGuardBand;
  throw InvalidInput("", 0, field,
                     "'" + name + "' is not a decision rule (simple, guarded, guard_band)");
}

double GuardBandPct(const nlohmann::json& v, const std::string& field) {
  if (!v.contains("guard_band_pct")) throw InvalidInput("", 0, field, "is required by guard_band");
  const auto& w = v["guard_band_pct"];
  if (!w.is_number() || !std::isfinite(w.get<double>()) || w.get<double>() <= 0.0 ||
      w.get<double>() > 100.0) {
    throw InvalidInput("", 0, field, "must be a number in (0, 100] (% of the limit)");
  }
  return w.get<double>();
}

}  // namespace

const char* ToString(Decision d) {
  switch (d) {
    case Decision::kWithin:
      return "within";
    case Decision::kBeyond:
      return "beyond";
    case Decision::kUndecided:
      return "undecided";
  }
  return "within";
}

Judgement Decide(double value, std::optional<double> U, double limit, const DecisionRule& rule) {
  Judgement j;
  j.u_known = U.has_value() && std::isfinite(*U) && *U >= 0.0;
  if (rule.kind == DecisionRule::Kind::kGuarded && j.u_known) j.guard_band = *U;
  if (rule.kind == DecisionRule::Kind::kGuardBand && j.u_known) {
    j.guard_band = rule.guard_band_pct / 100.0 * limit;
  }
  if (value + j.guard_band <= limit) {
    j.decision = Decision::kWithin;
  } else if (value - j.guard_band > limit) {
    j.decision = Decision::kBeyond;
  } else {
    j.decision = Decision::kUndecided;
  }
  return j;
}

DecisionRule ParseDecisionRule(const nlohmann::json& value, const std::string& field) {
  DecisionRule rule;
  if (value.is_null()) return rule;
  if (value.is_string()) {
    rule.kind = RuleKind(value.get<std::string>(), field);
    if (rule.kind == DecisionRule::Kind::kGuardBand) {
      throw InvalidInput("", 0, field,
                         "guard_band needs its width: {\"rule\": \"guard_band\", "
                         "\"guard_band_pct\": w}");
    }
    return rule;
  }
  if (!value.is_object()) {
    throw InvalidInput("", 0, field,
                       "must be \"simple\", \"guarded\" or {\"rule\", \"guard_band_pct\"}");
  }
  for (const auto& [key, v] : value.items()) {
    if (key != "rule" && key != "guard_band_pct" && key != "description") {
      throw InvalidInput("", 0, field + "." + key, "is not a key of a decision rule");
    }
  }
  if (!value.contains("rule") || !value["rule"].is_string()) {
    throw InvalidInput("", 0, field + ".rule", "must be simple, guarded or guard_band");
  }
  rule.kind = RuleKind(value["rule"].get<std::string>(), field + ".rule");
  if (rule.kind == DecisionRule::Kind::kGuardBand) {
    rule.guard_band_pct = GuardBandPct(value, field + ".guard_band_pct");
  } else if (value.contains("guard_band_pct")) {
    throw InvalidInput("", 0, field + ".guard_band_pct", "is only for the rule guard_band");
  }
  return rule;
}

nlohmann::json DecisionRuleJson(const DecisionRule& rule) {
  nlohmann::json j = {{"rule", RuleName(rule.kind)}};
  if (rule.kind == DecisionRule::Kind::kGuardBand) j["guard_band_pct"] = rule.guard_band_pct;
  j["description"] = DecisionRuleText(rule);
  return j;
}

std::string DecisionRuleText(const DecisionRule& rule) {
  switch (rule.kind) {
    case DecisionRule::Kind::kSimple:
      return "simple acceptance (ISO 14253-1, ILAC-G8): the value alone against the limit";
    case DecisionRule::Kind::kGuarded:
      return "guarded acceptance (ISO 14253-1, ILAC-G8): guard band w = U (k = 2); within its "
             "uncertainty of the limit is undecided";
    case DecisionRule::Kind::kGuardBand: {
      char text[200];
      std::snprintf(text, sizeof text,
                    "guard band (ILAC-G8) w = %g %% of the limit; within w of the limit is "
                    "undecided",
                    rule.guard_band_pct);
      return text;
    }
  }
  return "";
}

}  // namespace km::server
