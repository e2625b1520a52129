// The words of the PDF reports (usecases/pdf_reports_text.h): the names a reader knows the
// figures and input uncertainties by, uncertainties with 2 significant digits as the page prints
// them, and free text from a result or the service tidied for print (no identifiers, µm, at most
// 3 decimals).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include "usecases/pdf_reports_text.h"

namespace km::usecases::report_text {

using nlohmann::json;

std::string Sigma(const json& v) {
  if (!v.is_number()) return "—";
  const double x = v.get<double>();
  if (!std::isfinite(x)) return "—";
  if (x == 0.0) return "0";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.1e", std::abs(x));  // 2 significant digits
  const double rounded = std::strtod(buf, nullptr);
  const int decimals =
      std::min(12, std::max(0, 1 - static_cast<int>(std::floor(std::log10(rounded)))));
  return Fixed(x < 0 ? -rounded : rounded, decimals);
}

namespace {

struct Name {
  const char* key;
  const char* name;
};

// Figures by their key (the last part of a path).
constexpr Name kFigureNames[] = {
    {"accuracy_um", "bidirectional accuracy of positioning A"},
    {"accuracy_up_um", "unidirectional accuracy of positioning A↑"},
    {"accuracy_down_um", "unidirectional accuracy of positioning A↓"},
    {"systematic_deviation_um", "bidirectional systematic positioning error E"},
    {"systematic_deviation_up_um", "unidirectional systematic positioning error E↑"},
    {"systematic_deviation_down_um", "unidirectional systematic positioning error E↓"},
    {"mean_deviation_range_um", "range of the mean bidirectional positioning error M"},
    {"reversal_value_um", "reversal error B"},
    {"mean_reversal_value_um", "mean reversal error B̄"},
    {"repeatability_um", "bidirectional repeatability of positioning R"},
    {"repeatability_up_um", "unidirectional repeatability of positioning R↑"},
    {"repeatability_down_um", "unidirectional repeatability of positioning R↓"},
    {"circularity_um", "circularity F (least squares)"},
    {"min_zone_circularity_um", "circularity, minimum zone"},
    {"circular_deviation_um", "circular deviation G"},
    {"centre_offset_um", "centre offset"},
    {"average_radial_error_um", "average radial error"},
    {"circular_hysteresis_um", "circular hysteresis H"},
    {"circular_hysteresis_own_centres_um", "circular hysteresis H about each trace's centre"},
    {"bidirectional_circular_deviation_um", "bidirectional circular deviation G(b)"},
    {"radial_deviation_max_um", "largest radial deviation"},
    {"radial_deviation_min_um", "smallest radial deviation"},
    {"straightness_lsq_um", "straightness (least squares)"},
    {"straightness_min_zone_um", "straightness (minimum zone)"},
    {"flatness_lsq_um", "flatness (least squares)"},
    {"flatness_min_zone_um", "flatness (minimum zone)"},
    {"parallelism_um", "parallelism"},
    {"straightness_end_point_um", "straightness (end-point reference)"},
    {"range_um", "range of the readings"},
    {"slope_um_per_m", "slope of the least-squares line"},
    {"end_point_slope_um_per_m", "slope of the end-point line"},
    {"min_zone_slope_um_per_m", "slope of the minimum-zone lines"},
    {"slope_with_periodic_um_per_m", "slope with the periodic error fitted"},
    {"intercept_um", "intercept of the least-squares line"},
    {"length_mm", "length measured"},
    {"points", "points measured"},
    {"YOA_um", "YOA, position error of the A axis line in Y"},
    {"ZOA_um", "ZOA, position error of the A axis line in Z"},
    {"BOA_urad", "BOA, orientation error of the A axis line about Y"},
    {"COA_urad", "COA, orientation error of the A axis line about Z"},
    {"XOB_um", "XOB, position error of the B axis line in X"},
    {"ZOB_um", "ZOB, position error of the B axis line in Z"},
    {"AOB_urad", "AOB, orientation error of the B axis line about X"},
    {"COB_urad", "COB, orientation error of the B axis line about Z"},
    {"XOC_um", "XOC, position error of the C axis line in X"},
    {"YOC_um", "YOC, position error of the C axis line in Y"},
    {"AOC_urad", "AOC, orientation error of the C axis line about X"},
    {"BOC_urad", "BOC, orientation error of the C axis line about Y"},
};

// VDI/DGQ 3441 figures, under vdi3441.
constexpr Name kVdiNames[] = {{"P_um", "position uncertainty P"},
                              {"Ps_um", "positional scatter Ps"},
                              {"U_um", "reversal span U"},
                              {"Pa_um", "positional deviation Pa"}};

constexpr Name kInputNames[] = {{"u_laser_ppm", "laser (scale)"},
                                {"u_air_temperature_c", "air temperature"},
                                {"u_air_pressure_pa", "air pressure"},
                                {"u_air_humidity_pct", "air humidity"},
                                {"u_material_temperature_c", "material temperature"},
                                {"u_expansion_ppm_per_k", "expansion coefficient"},
                                {"u_reading_um", "reading"},
                                {"u_bar_length_um", "bar length"},
                                {"u_bar_temperature_c", "bar temperature"},
                                {"u_ranging_um", "ranging"}};

std::string Spaced(std::string s) {
  for (auto& c : s) {
    if (c == '_') c = ' ';
  }
  return s;
}

}  // namespace

std::string FigureName(const std::string& key) {
  const std::size_t dot = key.rfind('.');
  const std::string parent = dot == std::string::npos ? "" : key.substr(0, dot);
  const std::string last = dot == std::string::npos ? key : key.substr(dot + 1);
  if (parent == "vdi3441") {
    for (const auto& n : kVdiNames) {
      if (last == n.key) return std::string(n.name) + " (VDI/DGQ 3441)";
    }
  }
  for (const auto& n : kFigureNames) {
    if (last == n.key) return n.name;
  }
  std::string head;
  if (parent == "vdi3441") head = "VDI/DGQ 3441 ";
  if (parent == "iso230_4") head = "ISO 230-4 ";
  if (parent == "diagnosis") head = "diagnosis: ";
  if (head.empty() && !parent.empty()) head = Spaced(parent) + ": ";
  return head + LabelOf(last).label;
}

std::size_t FigureRank(const std::string& key) {
  const std::size_t dot = key.rfind('.');
  const std::string last = dot == std::string::npos ? key : key.substr(dot + 1);
  const std::size_t offset = dot == std::string::npos ? 0 : std::size(kFigureNames);
  for (std::size_t i = 0; i < std::size(kFigureNames); ++i) {
    if (last == kFigureNames[i].key) return offset + i;
  }
  for (std::size_t i = 0; i < std::size(kVdiNames); ++i) {
    if (last == kVdiNames[i].key) return offset + i;
  }
  return 2 * std::size(kFigureNames);
}

std::string InputName(const std::string& input) {
  for (const auto& n : kInputNames) {
    if (input == n.key) return n.name;
  }
  std::string label = LabelOf(input).label;
  return label.starts_with("u ") ? label.substr(2) : label;
}

std::string Capitalised(std::string s) {
  if (!s.empty() && s[0] >= 'a' && s[0] <= 'z') s[0] = static_cast<char>(s[0] - 'a' + 'A');
  return s;
}

std::string Readable(const std::string& text) {
  static const std::regex kIdentifier(
      R"(\b[A-Za-z][A-Za-z0-9]*(?:[._][A-Za-z0-9]+)*_[A-Za-z0-9]+\b)");
  static const std::regex kLong(R"(-?\d+\.\d{4,})");
  static const std::regex kUm(R"(\bum\b)");
  static const std::regex kNegativeZero(R"(-(0\.0+)(?![0-9]))");
  std::string out;
  // Identifiers: a figure's key by its name, others with spaces.
  auto begin = std::sregex_iterator(text.begin(), text.end(), kIdentifier);
  std::size_t at = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    const auto pos = static_cast<std::size_t>(m.position(0));
    // Part of a file name or path (…/positioning_x.txt) stays as it is.
    const std::size_t end = pos + static_cast<std::size_t>(m.length(0));
    const bool path = (pos > 0 && text[pos - 1] == '/') ||
                      (end + 1 < text.size() && text[end] == '.' &&
                       std::isalpha(static_cast<unsigned char>(text[end + 1])));
    out += text.substr(at, pos - at);
    const std::string word = m.str(0);
    if (path) {
      out += word;
    } else {
      const std::string name = FigureName(word);
      out += name == LabelOf(word).label ? Spaced(word) : name;
    }
    at = end;
  }
  out += text.substr(at);
  // Numbers with at most 3 decimals.
  std::string rounded;
  at = 0;
  for (auto it = std::sregex_iterator(out.begin(), out.end(), kLong); it != std::sregex_iterator();
       ++it) {
    const auto pos = static_cast<std::size_t>(it->position(0));
    rounded += out.substr(at, pos - at) + Fixed(std::stod(it->str(0)), 3);
    at = pos + static_cast<std::size_t>(it->length(0));
  }
  rounded += out.substr(at);
  rounded = std::regex_replace(rounded, kUm, "µm");
  return std::regex_replace(rounded, kNegativeZero, "$1");
}

}  // namespace km::usecases::report_text
