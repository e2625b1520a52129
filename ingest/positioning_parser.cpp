#include "ingest/positioning_parser.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <utility>

#include "analysis/core/errors.h"

namespace km::ingest {
namespace {

TextTable Read(std::string_view bytes, const std::string& file, const TextLimits& limits) {
  ReadOptions options;
  static_cast<TextLimits&>(options) = limits;
  options.keep_column = [](std::string_view name) {
    return name == "run" || name == "direction" || name == "target_mm" || name == "measured_mm" ||
           name == "deviation_um";
  };
  options.word_columns["direction"] = {{"+", 1.0}, {"-", -1.0}};
  TextTable t = ReadTextTable(bytes, file, options);
  if (t.format != kPositioningFormat) {
    throw InvalidInput(
        file, t.format_line, "format",
        "expected '" + std::string(kPositioningFormat) + "', found '" + t.format + "'");
  }
  if (!t.markers.empty()) {
    throw InvalidInput(file, t.markers.front().line, t.markers.front().key,
                       "header lines must come before the column-header row");
  }
  return t;
}

// The air conditions of a file read with n = 1; out-of-range values name their header line.
positioning::AirConditions ReadAir(const TextTable& t) {
  positioning::AirConditions air;
  air.temperature_c = t.RequireNumber("air_temperature_c");
  air.pressure_pa = t.RequireNumber("air_pressure_pa");
  air.humidity_pct = t.RequireNumber("air_humidity_pct");
  air.wavelength_nm = t.RequireNumber("laser_wavelength_nm");
  try {
    positioning::CheckAirConditions(air);
  } catch (const InvalidInput& e) {
    throw InvalidInput(t.file, t.KeyLine(e.field()), e.field(), e.reason());
  }
  return air;
}

void ReadMaterial(const TextTable& t, positioning::CorrectionSettings& c) {
  const bool has_t = t.Has("material_temperature_c");
  const bool has_a = t.Has("expansion_ppm_per_k");
  if (has_t != has_a) {
    const std::string given = has_t ? "material_temperature_c" : "expansion_ppm_per_k";
    throw InvalidInput(t.file, t.KeyLine(given),
                       has_t ? "expansion_ppm_per_k" : "material_temperature_c",
                       given + " needs material_temperature_c and expansion_ppm_per_k together");
  }
  if (!has_t) return;
  const double temp = t.RequireNumber("material_temperature_c");
  const double alpha = t.RequireNumber("expansion_ppm_per_k");
  if (temp < -50.0 || temp > 100.0) {
    throw InvalidInput(t.file, t.KeyLine("material_temperature_c"), "material_temperature_c",
                       "a machine temperature must be within −50 … 100 °C");
  }
  if (alpha < 0.0 || alpha > 100.0) {
    throw InvalidInput(t.file, t.KeyLine("expansion_ppm_per_k"), "expansion_ppm_per_k",
                       "an expansion coefficient must be within 0 … 100 ppm/K");
  }
  c.material_temperature_c = temp;
  c.expansion_ppm_per_k = alpha;
}

// The input uncertainties (docs/formats.md §1.8) must have a correction to act through: the air
// ones the refractive index kinemetric applies to raw readings, the material ones the correction
// to 20 °C. The generic reader checks each is a finite number ≥ 0; here each is also at most a
// bound far beyond any instrument's (a larger one is a typing error, and would carry the drawn
// readings out of the range the corrections hold for).
void CheckUncertaintyKeys(const TextTable& t, const PositioningFile& f) {
  struct Bound {
    const char* key;
    double most;
    const char* text;
  };
  static const Bound kBounds[] = {
      {"u_laser_ppm", 1000.0, "1000 ppm"},         {"u_air_temperature_c", 10.0, "10 °C"},
      {"u_air_pressure_pa", 10000.0, "10 000 Pa"}, {"u_air_humidity_pct", 50.0, "50 %"},
      {"u_material_temperature_c", 10.0, "10 °C"}, {"u_expansion_ppm_per_k", 50.0, "50 ppm/K"}};
  for (const Bound& b : kBounds) {
    const auto v = t.OptionalNumber(b.key);
    if (v && !(*v >= 0.0 && *v <= b.most)) {
      throw InvalidInput(t.file, t.KeyLine(b.key), b.key,
                         std::string("a standard uncertainty must be within 0 … ") + b.text);
    }
  }
  if (f.air_compensated) {
    for (const char* key : {"u_air_temperature_c", "u_air_pressure_pa", "u_air_humidity_pct"}) {
      if (!t.Has(key)) continue;
      throw InvalidInput(t.file, t.KeyLine(key), key,
                         "applies to raw readings (air_compensated: no) only; with "
                         "air_compensated: yes the laser's own air compensation belongs in "
                         "u_laser_ppm");
    }
  }
  if (!f.corrections.material_temperature_c) {
    for (const char* key : {"u_material_temperature_c", "u_expansion_ppm_per_k"}) {
      if (!t.Has(key)) continue;
      throw InvalidInput(t.file, t.KeyLine(key), key,
                         "needs material_temperature_c and expansion_ppm_per_k: without the "
                         "correction to 20 °C it has nothing to act through");
    }
  }
}

void ReadHeader(const TextTable& t, PositioningFile& f) {
  f.machine_id = t.RequireMachineId();
  f.axis = t.RequireString("axis");
  for (char& c : f.axis) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  // A machine axis name: a letter, then letters or digits (X, Y, Z, U, V, W, X2 of a gantry).
  const bool named = !f.axis.empty() && f.axis.size() <= 8 &&
                     std::isalpha(static_cast<unsigned char>(f.axis[0])) &&
                     std::all_of(f.axis.begin(), f.axis.end(), [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) != 0;
                     });
  if (!named) {
    throw InvalidInput(t.file, t.KeyLine("axis"), "axis",
                       Quote(f.axis) + " is not an axis name (a letter, then letters or digits, " +
                           "at most 8: X, Y, Z, U, V, W, X2)");
  }
  if (t.Has("timestamp")) f.timestamp = t.RequireString("timestamp");
  f.cycle = t.RequireOneOf("cycle", {"linear", "pendulum", "step"});
  f.corrections.datum_mm = t.RequireNumber("datum_mm");
  f.air_compensated = t.RequireOneOf("air_compensated", {"yes", "no"}) == "yes";
  if (!f.air_compensated) f.corrections.air = ReadAir(t);
  ReadMaterial(t, f.corrections);
  CheckUncertaintyKeys(t, f);
  f.metadata = t.Metadata();
}

void CheckCell(const TextTable& t, std::size_t row, const char* field, double v, double limit) {
  if (std::abs(v) > limit) {
    throw InvalidInput(t.file, t.row_lines[row], field,
                       "|value| must be at most " + std::to_string(limit));
  }
}

void ReadRows(const TextTable& t, PositioningFile& f) {
  const std::size_t ir = t.RequireColumn("run");
  const std::size_t id = t.RequireColumn("direction");
  const std::size_t it = t.RequireColumn("target_mm");
  const bool measured = t.ColumnIndex("measured_mm") >= 0;
  if (measured == (t.ColumnIndex("deviation_um") >= 0)) {
    throw InvalidInput(t.file, t.columns_line, "measured_mm",
                       "give exactly one of the columns measured_mm and deviation_um");
  }
  f.value_column = measured ? "measured_mm" : "deviation_um";
  const std::size_t iv = t.RequireColumn(f.value_column);
  f.readings.reserve(t.NumRows());
  for (std::size_t row = 0; row < t.NumRows(); ++row) {
    const double run = t.Column(ir)[row];
    if (run != std::floor(run) || run < 0 || run > 1e6) {
      throw InvalidInput(t.file, t.row_lines[row], "run", "a run is a whole number 0 … 1000000");
    }
    positioning::Reading r;
    r.run = static_cast<long>(run);
    r.direction = t.Column(id)[row] > 0 ? 1 : -1;
    r.target_mm = t.Column(it)[row];
    CheckCell(t, row, "target_mm", r.target_mm, 1e5);
    const double v = t.Column(iv)[row];
    CheckCell(t, row, f.value_column.c_str(), measured ? v - r.target_mm : v / 1000.0, 100.0);
    r.deviation_um = measured ? (v - r.target_mm) * 1000.0 : v;
    r.line = t.row_lines[row];
    f.readings.push_back(r);
  }
  if (f.readings.empty()) throw InvalidInput(t.file, t.columns_line, "run", "no data rows");
}

}  // namespace

TextLimits DefaultPositioningLimits() {
  TextLimits l;
  l.max_rows = 1'000'000;
  l.max_columns = 16;
  return l;
}

PositioningFile ParsePositioningFile(std::string_view bytes, const std::string& file,
                                     const TextLimits& limits) {
  const TextTable t = Read(bytes, file, limits);
  PositioningFile f;
  f.file = file;
  ReadHeader(t, f);
  ReadRows(t, f);
  return f;
}

}  // namespace km::ingest
