#include "server/audits/accuracy_audit.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>

#include "analysis/core/errors.h"

namespace km::server {
namespace {

using nlohmann::json;
using Extractor = std::function<std::optional<double>(const json&)>;

std::optional<double> Number(const json& j) {
  if (!j.is_number()) return std::nullopt;
  const double v = j.get<double>();
  if (!std::isfinite(v)) return std::nullopt;
  return std::abs(v);
}

// A number, or the length of a vector of numbers ([x, y] centre offsets).
std::optional<double> Magnitude(const json& j) {
  if (j.is_number()) return Number(j);
  if (!j.is_array() || j.empty()) return std::nullopt;
  double sum = 0.0;
  for (const auto& c : j) {
    const auto v = Number(c);
    if (!v) return std::nullopt;
    sum += *v * *v;
  }
  return std::sqrt(sum);
}

Extractor At(const char* pointer) {
  const json::json_pointer p(pointer);
  return [p](const json& r) -> std::optional<double> {
    if (!r.contains(p)) return std::nullopt;
    return Magnitude(r.at(p));
  };
}

// The largest of one value over the elements of an array (by a pointer into each element).
Extractor MaxOver(const char* array, const char* pointer, bool vector_length) {
  const json::json_pointer a(array);
  const json::json_pointer p(pointer);
  return [a, p, vector_length](const json& r) -> std::optional<double> {
    if (!r.contains(a) || !r.at(a).is_array()) return std::nullopt;
    std::optional<double> best;
    for (const auto& e : r.at(a)) {
      const json& v = p.empty() ? e : (e.contains(p) ? e.at(p) : json());
      const auto x = vector_length ? Magnitude(v) : Number(v);
      if (x && (!best || *x > *best)) best = x;
    }
    return best;
  };
}

// The largest change of a strut offset between a calibration and the one before it, from
// {"newest": result, "previous": result}; nullopt unless both hold as many finite offsets.
std::optional<double> StrutOffsetChange(const json& pair) {
  const json::json_pointer p("/parameters/strut_offset_um");
  if (!pair.is_object() || !pair.contains("newest") || !pair.contains("previous")) {
    return std::nullopt;
  }
  const json& a = pair["newest"];
  const json& b = pair["previous"];
  if (!a.contains(p) || !b.contains(p)) return std::nullopt;
  const json& x = a.at(p);
  const json& y = b.at(p);
  if (!x.is_array() || !y.is_array() || x.empty() || x.size() != y.size()) return std::nullopt;
  double best = 0.0;
  for (std::size_t j = 0; j < x.size(); ++j) {
    if (!x[j].is_number() || !y[j].is_number()) return std::nullopt;
    const double d = std::abs(x[j].get<double>() - y[j].get<double>());
    if (!std::isfinite(d)) return std::nullopt;
    best = std::max(best, d);
  }
  return best;
}

struct Entry {
  AuditMetric metric;
  Extractor extract;
};

const std::vector<Entry>& Table() {
  static const std::vector<Entry> table = {
      {{"dbb", "circularity_um", "", "µm", "circularity F, [PM-600 report] eq. 4.8",
        "/circularity_um"},
       At("/circularity_um")},
      {{"dbb", "min_zone_circularity_um", "", "µm", "minimum-zone circularity",
        "/min_zone_circularity_um"},
       At("/min_zone_circularity_um")},
      {{"dbb", "circular_deviation_um", "", "µm", "ISO 230-4 circular deviation G",
        "/iso230_4/circular_deviation_um"},
       At("/iso230_4/circular_deviation_um")},
      {{"dbb", "centre_offset_um", "", "µm", "length of the centre offset [x, y]",
        "|/centre_offset_um|"},
       At("/centre_offset_um")},
      {{"dbb", "average_radial_error_um", "", "µm", "magnitude of the average radial error",
        "|/average_radial_error_um|"},
       At("/average_radial_error_um")},
      {{"dbb", "circular_hysteresis_um", "dbb-pair", "µm",
        "ISO 230-4 circular hysteresis H of the newest test with its opposite-direction partner",
        "/pair/circular_hysteresis_um"},
       At("/pair/circular_hysteresis_um")},
      {{"dbb", "diagnosis.<effect>", "", "effect's unit",
        "magnitude of a diagnosed effect's value (docs/formats.md §4), e.g. diagnosis.backlash_x",
        "|/diagnosis[effect]/value|"},
       nullptr},
      {{"straightness", "straightness_lsq_um", "", "µm", "least-squares straightness",
        "/straightness_lsq_um"},
       At("/straightness_lsq_um")},
      {{"straightness", "straightness_min_zone_um", "", "µm", "minimum-zone straightness",
        "/straightness_min_zone_um"},
       At("/straightness_min_zone_um")},
      {{"flatness", "flatness_lsq_um", "", "µm", "least-squares flatness", "/flatness_lsq_um"},
       At("/flatness_lsq_um")},
      {{"flatness", "flatness_min_zone_um", "", "µm", "minimum-zone flatness",
        "/flatness_min_zone_um"},
       At("/flatness_min_zone_um")},
      {{"parallelism", "parallelism_um", "", "µm", "parallelism", "/parallelism_um"},
       At("/parallelism_um")},
      {{"positioning", "accuracy_um", "", "µm", "ISO 230-2 accuracy A (bidirectional)",
        "/accuracy_um"},
       At("/accuracy_um")},
      {{"positioning", "reversal_value_um", "", "µm", "ISO 230-2 reversal value B",
        "/reversal_value_um"},
       At("/reversal_value_um")},
      {{"positioning", "repeatability_um", "", "µm", "ISO 230-2 repeatability R (bidirectional)",
        "/repeatability_um"},
       At("/repeatability_um")},
      {{"positioning", "systematic_deviation_um", "", "µm",
        "ISO 230-2 systematic positioning deviation E (bidirectional)", "/systematic_deviation_um"},
       At("/systematic_deviation_um")},
      {{"positioning", "mean_deviation_range_um", "", "µm",
        "ISO 230-2 range of the mean bidirectional deviations M", "/mean_deviation_range_um"},
       At("/mean_deviation_range_um")},
      {{"tracker", "volumetric_error_max_um", "", "µm",
        "largest length of the volumetric error vectors", "max |/volumetric_error_um[i]|"},
       MaxOver("/volumetric_error_um", "", true)},
      {{"tracker", "residual_rms_um", "", "µm", "self-calibration residual (RMS)",
        "/residual_rms_um"},
       At("/residual_rms_um")},
      {{"servo", "joint_level", "servo-joints", "level",
        "joint-health level of the newest estimate (1 normal, 2 warn, 3 stop)", "/level"},
       At("/level")},
      {{"servo", "joint_resistance_max_Nm", "servo-joints", "N·m",
        "largest rotational joint resistance of the legs", "max /legs[i]/resistance_Nm"},
       MaxOver("/legs", "/resistance_Nm", false)},
      {{"servo", "joint_resistance_ratio_max", "servo-joints", "1",
        "largest resistance of a leg over its reference", "max /legs[i]/ratio"},
       MaxOver("/legs", "/ratio", false)},
      {{"calibration", "strut_offset_max_um", "hexapod_calibration", "µm",
        "largest identified strut length offset (true − nominal) of the newest hexapod "
        "calibration",
        "max |/parameters/strut_offset_um[j]|"},
       MaxOver("/parameters/strut_offset_um", "", false)},
      {{"calibration", "strut_offset_change_max_um", "hexapod_calibration-pair", "µm",
        "largest change of a strut offset from the calibration before the newest",
        "max |Δ /parameters/strut_offset_um[j]|"},
       StrutOffsetChange},
  };
  return table;
}

// The rotary-axis location errors of an R-test (docs/formats.md §3.18), magnitudes of the
// values; an error the poses do not determine has value null, so its rule is not evaluated for
// that set-up. AC tables name YOA … COA, BC tables XOB … COB, both XOC … BOC.
const std::vector<Entry>& RotaryTable() {
  static const std::vector<Entry> table = [] {
    struct Error {
      const char* key;
      const char* what;
    };
    static const Error kErrors[] = {
        {"YOA_um", "Y position error of the A axis line (AC table)"},
        {"ZOA_um", "Z position error of the A axis line (AC table)"},
        {"BOA_urad", "orientation error of the A axis line about Y (AC table)"},
        {"COA_urad", "orientation error of the A axis line about Z (AC table)"},
        {"XOB_um", "X position error of the B axis line (BC table)"},
        {"ZOB_um", "Z position error of the B axis line (BC table)"},
        {"AOB_urad", "orientation error of the B axis line about X (BC table)"},
        {"COB_urad", "orientation error of the B axis line about Z (BC table)"},
        {"XOC_um", "X position error of the C axis line"},
        {"YOC_um", "Y position error of the C axis line"},
        {"AOC_urad", "orientation error of the C axis line about X"},
        {"BOC_urad", "orientation error of the C axis line about Y"},
    };
    std::vector<Entry> out;
    for (const auto& e : kErrors) {
      const std::string key = e.key;
      const bool angular = key.size() > 5 && key.substr(key.size() - 5) == "_urad";
      const std::string pointer = "/location_errors/" + key + "/value";
      out.push_back(
          {{"rotary", key, "", angular ? "µrad" : "µm",
            std::string("rotary-axis location error ") + key.substr(0, key.find('_')) + ": " +
                e.what + " (ISO 230-1; not evaluated when the poses do not determine it)",
            "|" + pointer + "|"},
           At(pointer.c_str())});
    }
    return out;
  }();
  return table;
}

// Every metric with a fixed name: the table, then the rotary location errors.
const std::vector<Entry>& AllEntries() {
  static const std::vector<Entry> all = [] {
    std::vector<Entry> out = Table();
    const auto& rotary = RotaryTable();
    out.insert(out.end(), rotary.begin(), rotary.end());
    return out;
  }();
  return all;
}

// Effect names a DBB diagnosis reports (docs/formats.md §4), the axis letters of any plane.
bool KnownEffect(const std::string& name) {
  static const char* const kPlain[] = {"centre_offset",  "radius_error", "servo_lag",
                                       "servo_mismatch", "squareness",   "scale_mismatch",
                                       "stick_slip"};
  static const char* const kAxis[] = {"backlash", "reversal_spike", "lateral_play", "cyclic_error",
                                      "straightness"};
  for (const char* p : kPlain) {
    if (name == p) return true;
  }
  if (name.size() < 3 || name[name.size() - 2] != '_') return false;
  const char axis = name.back();
  if (axis != 'x' && axis != 'y' && axis != 'z') return false;
  const std::string base = name.substr(0, name.size() - 2);
  return std::any_of(std::begin(kAxis), std::end(kAxis), [&](const char* a) { return base == a; });
}

constexpr const char* kDiagnosisPrefix = "diagnosis.";

}  // namespace

bool MachineWideKind(const std::string& kind) {
  return kind == "servo" || kind == "calibration";
}

const std::vector<AuditMetric>& AuditMetrics() {
  static const std::vector<AuditMetric> metrics = [] {
    std::vector<AuditMetric> out;
    for (const auto& e : AllEntries()) out.push_back(e.metric);
    return out;
  }();
  return metrics;
}

static bool TakesTolerances(const std::string& kind) {
  return kind == "dbb" || kind == "straightness" || kind == "flatness" || kind == "parallelism" ||
         kind == "positioning" || kind == "tracker" || kind == "rotary";
}

std::optional<AuditMetric> FindAuditMetric(const std::string& kind, const std::string& metric) {
  if (metric == kConformanceMetric) {
    if (!TakesTolerances(kind)) return std::nullopt;
    return AuditMetric{kind,
                       kConformanceMetric,
                       kConformanceMetric,
                       "figures",
                       "figures of the set-up's newest test that do not meet the machine's "
                       "tolerances (GET /api/v1/machines/{id}/tolerances)",
                       "count of /conformance/figures[verdict != pass]"};
  }
  if (kind == "dbb" && metric.rfind(kDiagnosisPrefix, 0) == 0) {
    const std::string effect = metric.substr(std::string(kDiagnosisPrefix).size());
    if (!KnownEffect(effect)) return std::nullopt;
    AuditMetric m{"dbb",
                  metric,
                  "",
                  "effect's unit",
                  "diagnosed " + effect,
                  "|/diagnosis[effect=" + effect + "]/value|"};
    return m;
  }
  if (const auto dot = metric.find('.'); kind == "positioning" && dot != std::string::npos) {
    const std::string axis = metric.substr(dot + 1);
    if (axis.empty() || axis.size() > 8 || !std::all_of(axis.begin(), axis.end(), [](char c) {
          return std::isupper(static_cast<unsigned char>(c)) ||
                 std::isdigit(static_cast<unsigned char>(c));
        })) {
      return std::nullopt;
    }
    auto m = FindAuditMetric(kind, metric.substr(0, dot));
    if (!m) return std::nullopt;
    m->metric = metric;
    m->description += " of axis " + axis;
    return m;
  }
  for (const auto& e : AllEntries()) {
    if (e.extract && e.metric.kind == kind && e.metric.metric == metric) return e.metric;
  }
  return std::nullopt;
}

std::string AuditMetricTestId(const AuditMetric& metric) {
  const auto dot = metric.metric.find('.');
  if (metric.kind != "positioning" || dot == std::string::npos) return {};
  return metric.metric.substr(dot + 1);
}

std::optional<double> ExtractAuditMetric(const AuditMetric& metric, const json& result) {
  if (metric.metric.rfind(kDiagnosisPrefix, 0) == 0) {
    const std::string effect = metric.metric.substr(std::string(kDiagnosisPrefix).size());
    if (!result.contains("diagnosis") || !result["diagnosis"].is_array()) return std::nullopt;
    for (const auto& d : result["diagnosis"]) {
      if (d.is_object() && d.value("effect", "") == effect && d.contains("value")) {
        return Magnitude(d["value"]);
      }
    }
    return std::nullopt;
  }
  // A metric of one axis reads the figure of its base name ("accuracy_um.X" → accuracy_um).
  const std::string base = AuditMetricTestId(metric).empty()
                               ? metric.metric
                               : metric.metric.substr(0, metric.metric.find('.'));
  for (const auto& e : AllEntries()) {
    if (e.extract && e.metric.kind == metric.kind && e.metric.metric == base) {
      return e.extract(result);
    }
  }
  return std::nullopt;
}

std::optional<double> ExtractAuditUncertainty(const AuditMetric& metric, const json& result) {
  if (!result.is_object()) return std::nullopt;
  const std::string figure = metric.metric.substr(0, metric.metric.find('.'));
  const json* holder = &result;
  if (metric.analysis == "dbb-pair") {
    if (!result.contains("pair") || !result["pair"].is_object()) return std::nullopt;
    holder = &result["pair"];
  }
  const json::json_pointer p("/uncertainty/figures");
  if (!holder->contains(p) || !holder->at(p).is_object()) return std::nullopt;
  const json& figures = holder->at(p);
  if (!figures.contains(figure) || !figures[figure].is_object()) return std::nullopt;
  const json& f = figures[figure];
  if (!f.contains("U_um") || !f["U_um"].is_number()) return std::nullopt;
  const double U = f["U_um"].get<double>();
  if (!std::isfinite(U) || U < 0) return std::nullopt;
  return U;
}

namespace {

InvalidInput RuleError(std::size_t i, const std::string& key, const std::string& why) {
  return InvalidInput("", 0, "rules[" + std::to_string(i) + "]" + (key.empty() ? "" : "." + key),
                      why);
}

std::optional<double> Limit(const json& rule, std::size_t i, const char* key) {
  if (!rule.contains(key) || rule[key].is_null()) return std::nullopt;
  if (!rule[key].is_number() || !std::isfinite(rule[key].get<double>())) {
    throw RuleError(i, key, "must be a finite number");
  }
  const double v = rule[key].get<double>();
  if (v < 0) throw RuleError(i, key, "must be ≥ 0 (metrics are magnitudes)");
  return v;
}

std::string Text(const json& rule, std::size_t i, const char* key) {
  if (!rule.contains(key)) throw RuleError(i, key, "is missing");
  if (!rule[key].is_string()) throw RuleError(i, key, "must be a string");
  return rule[key].get<std::string>();
}

void ParseChange(const json& r, std::size_t i, AuditRule& rule) {
  if (!r.contains("change") || r["change"].is_null()) {
    if (r.contains("days")) throw RuleError(i, "days", "is only for \"change\": \"days\"");
    return;
  }
  const std::string change = Text(r, i, "change");
  if (change == "previous_audit") {
    rule.change = AuditRule::Change::kPreviousAudit;
    if (r.contains("days")) throw RuleError(i, "days", "is only for \"change\": \"days\"");
  } else if (change == "days") {
    rule.change = AuditRule::Change::kDays;
    if (!r.contains("days") || !r["days"].is_number_integer() ||
        r["days"].get<std::int64_t>() < 1 || r["days"].get<std::int64_t>() > 3660) {
      throw RuleError(i, "days", "must be a whole number of days from 1 to 3660");
    }
    rule.days = r["days"].get<std::int64_t>();
  } else {
    throw RuleError(i, "change", "'" + change + "' is neither \"previous_audit\" nor \"days\"");
  }
}

// A conformance rule's "level" (2 or 3; 3 without limits): short for warn 0 or stop 0, so that a
// set-up failing its tolerances is a finding of that level.
void ConformanceLevel(const json& r, std::size_t i, AuditRule& rule) {
  const bool conformance = rule.metric == kConformanceMetric;
  if (!r.contains("level")) {
    if (conformance && !rule.warn && !rule.stop) rule.stop = 0.0;
    return;
  }
  if (!conformance) throw RuleError(i, "level", "is only for the metric \"conformance\"");
  if (rule.warn || rule.stop) throw RuleError(i, "level", "give a level or limits, not both");
  if (r["level"] == 2) {
    rule.warn = 0.0;
  } else if (r["level"] == 3) {
    rule.stop = 0.0;
  } else {
    throw RuleError(i, "level", "must be 2 (warn) or 3 (stop)");
  }
}

AuditRule ParseRule(const json& r, std::size_t i) {
  if (!r.is_object()) throw RuleError(i, "", "must be an object");
  static const char* const kKeys[] = {"kind", "metric",  "warn", "stop",      "change",
                                      "days", "test_id", "axis", "direction", "level"};
  for (const auto& item : r.items()) {
    const std::string key = item.key();
    if (std::none_of(std::begin(kKeys), std::end(kKeys), [&](const char* k) { return key == k; })) {
      throw RuleError(
          i, key,
          "is not a rule key (kind, metric, warn, stop, change, days, test_id, direction, axis, "
          "level)");
    }
  }
  AuditRule rule;
  rule.kind = Text(r, i, "kind");
  if (std::none_of(AuditMetrics().begin(), AuditMetrics().end(),
                   [&](const AuditMetric& m) { return m.kind == rule.kind; })) {
    throw RuleError(i, "kind",
                    "'" + rule.kind + "' is not a kind an audit reads (GET /api/v1/audit-metrics)");
  }
  rule.metric = Text(r, i, "metric");
  if (!FindAuditMetric(rule.kind, rule.metric)) {
    throw RuleError(i, "metric",
                    "'" + rule.metric + "' is not a metric of kind '" + rule.kind +
                        "' (GET /api/v1/audit-metrics)");
  }
  rule.scope = ParseSetUpScope(r, rule.kind, "rules[" + std::to_string(i) + "]");
  if (MachineWideKind(rule.kind) &&
      (rule.scope.test_id || rule.scope.direction || rule.scope.axis)) {
    throw RuleError(i, "test_id",
                    "kind '" + rule.kind + "' is judged for the whole machine: it takes no scope");
  }
  rule.warn = Limit(r, i, "warn");
  rule.stop = Limit(r, i, "stop");
  ConformanceLevel(r, i, rule);
  if (!rule.warn && !rule.stop) throw RuleError(i, "warn", "a rule needs warn, stop or both");
  if (rule.warn && rule.stop && *rule.warn > *rule.stop) {
    throw RuleError(i, "warn", "must be ≤ stop");
  }
  ParseChange(r, i, rule);
  if (rule.metric == kConformanceMetric && rule.change != AuditRule::Change::kNone) {
    throw RuleError(i, "change", "conformance is judged as it stands, not as a trend");
  }
  return rule;
}

}  // namespace

std::vector<AuditRule> ParseAuditRules(const json& rules) {
  if (!rules.is_array()) throw InvalidInput("", 0, "rules", "must be an array of rules");
  if (rules.size() > kMaxAuditRules) {
    throw InvalidInput("", 0, "rules",
                       "holds " + std::to_string(rules.size()) + " rules; at most " +
                           std::to_string(kMaxAuditRules));
  }
  std::vector<AuditRule> out;
  for (std::size_t i = 0; i < rules.size(); ++i) out.push_back(ParseRule(rules[i], i));
  return out;
}

json AuditRuleJson(const AuditRule& rule) {
  json j = {{"kind", rule.kind}, {"metric", rule.metric}};
  AddScopeJson(rule.scope, j);
  j["warn"] = rule.warn ? json(*rule.warn) : json(nullptr);
  j["stop"] = rule.stop ? json(*rule.stop) : json(nullptr);
  if (rule.change == AuditRule::Change::kPreviousAudit) j["change"] = "previous_audit";
  if (rule.change == AuditRule::Change::kDays) {
    j["change"] = "days";
    j["days"] = rule.days;
  }
  return j;
}

}  // namespace km::server
