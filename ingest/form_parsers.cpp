#include "ingest/form_parsers.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <set>
#include <utility>

#include "analysis/core/errors.h"
#include "ingest/text_format.h"

namespace km::ingest {
namespace {

TextTable ReadForm(std::string_view bytes, const std::string& file, std::string_view format,
                   const TextLimits& limits, std::set<std::string> columns) {
  ReadOptions options;
  static_cast<TextLimits&>(options) = limits;
  options.keep_column = [columns = std::move(columns)](std::string_view name) {
    return columns.count(std::string(name)) > 0;
  };
  TextTable t = ReadTextTable(bytes, file, options);
  if (t.format != format) {
    throw InvalidInput(file, t.format_line, "format",
                       "expected '" + std::string(format) + "', found '" + t.format + "'");
  }
  if (!t.markers.empty()) {
    throw InvalidInput(file, t.markers.front().line, t.markers.front().key,
                       "header lines must come before the column-header row");
  }
  return t;
}

std::string Upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string RequireAxis(const TextTable& t, const std::string& key) {
  const std::string v = Upper(t.RequireString(key));
  static const std::set<std::string> kAxes{"X", "Y", "Z", "U", "V", "W"};
  if (!kAxes.count(v)) {
    throw InvalidInput(t.file, t.KeyLine(key), key,
                       Quote(v) + " is not an axis (X, Y, Z, U, V or W)");
  }
  return v;
}

void RequireRows(const TextTable& t, std::size_t min_rows, const std::string& field) {
  if (t.NumRows() < min_rows) {
    const std::size_t line = t.row_lines.empty() ? t.columns_line : t.row_lines.back();
    throw InvalidInput(t.file, line, field,
                       "found " + std::to_string(t.NumRows()) + " data rows; at least " +
                           std::to_string(min_rows) + " are needed");
  }
}

// position_mm, deviation_um with strictly increasing positions; the columns move out of the
// table.
form::Profile ReadProfile(TextTable& t, std::size_t min_rows) {
  const std::size_t ip = t.RequireColumn("position_mm");
  const std::size_t id = t.RequireColumn("deviation_um");
  RequireRows(t, min_rows, "position_mm");
  const std::vector<double>& x = t.Column(ip);
  for (std::size_t i = 1; i < x.size(); ++i) {
    if (!(x[i] > x[i - 1])) {
      throw InvalidInput(t.file, t.row_lines[i], "position_mm",
                         "positions must be strictly increasing (previous value on line " +
                             std::to_string(t.row_lines[i - 1]) + ")");
    }
  }
  form::Profile p;
  p.position_mm = std::move(t.values[ip]);
  p.deviation_um = std::move(t.values[id]);
  return p;
}

const std::set<std::string> kProfileColumns{"position_mm", "deviation_um"};

}  // namespace

TextLimits DefaultFormLimits() {
  TextLimits l;
  l.max_rows = 1'000'000;
  l.max_columns = 32;
  return l;
}

StraightnessFile ParseStraightnessFile(std::string_view bytes, const std::string& file,
                                       const TextLimits& limits) {
  TextTable t = ReadForm(bytes, file, kStraightnessFormat, limits, kProfileColumns);
  StraightnessFile f;
  f.file = file;
  f.machine_id = t.RequireMachineId();
  f.axis = RequireAxis(t, "axis");
  f.error_direction = RequireAxis(t, "error_direction");
  if (f.error_direction == f.axis) {
    throw InvalidInput(file, t.KeyLine("error_direction"), "error_direction",
                       "must differ from the travel axis " + f.axis);
  }
  f.sensor = t.RequireOneOf("sensor", {"capacitance", "laser", "indicator"});
  f.reference = t.RequireString("reference");
  if (t.Has("reversal")) {
    f.reversal = t.RequireOneOf("reversal", {"a", "b"});
    f.reversal_line = t.KeyLine("reversal");
    if (!t.Has("pair_id")) {
      throw InvalidInput(file, t.KeyLine("reversal"), "pair_id",
                         "a reversal profile needs a pair_id");
    }
    f.pair_id = t.RequireString("pair_id");
    f.reversal_setup = "artefact";
    if (t.Has("reversal_setup")) {
      f.reversal_setup = t.RequireOneOf("reversal_setup", {"artefact", "artefact_and_sensor"});
      f.reversal_setup_line = t.KeyLine("reversal_setup");
    }
  } else {
    for (const char* key : {"pair_id", "reversal_setup"}) {
      if (t.Has(key)) {
        throw InvalidInput(file, t.KeyLine(key), "reversal",
                           std::string(key) + " given without reversal (a or b)");
      }
    }
  }
  f.metadata = t.Metadata();
  f.profile = ReadProfile(t, kMinStraightnessPoints);
  f.row_lines = std::move(t.row_lines);
  return f;
}

ParallelismFile ParseParallelismFile(std::string_view bytes, const std::string& file,
                                     const TextLimits& limits) {
  TextTable t = ReadForm(bytes, file, kParallelismFormat, limits, kProfileColumns);
  ParallelismFile f;
  f.file = file;
  f.machine_id = t.RequireMachineId();
  f.axis = RequireAxis(t, "axis");
  f.datum = t.RequireString("datum");
  f.metadata = t.Metadata();
  f.profile = ReadProfile(t, kMinParallelismPoints);
  f.row_lines = std::move(t.row_lines);
  return f;
}

FlatnessFile ParseFlatnessFile(std::string_view bytes, const std::string& file,
                               const TextLimits& limits) {
  TextTable t = ReadForm(bytes, file, kFlatnessFormat, limits, {"x_mm", "y_mm", "z_um"});
  FlatnessFile f;
  f.file = file;
  f.machine_id = t.RequireMachineId();
  if (t.Has("datum")) f.datum = t.RequireString("datum");
  f.metadata = t.Metadata();
  const std::size_t ix = t.RequireColumn("x_mm");
  const std::size_t iy = t.RequireColumn("y_mm");
  const std::size_t iz = t.RequireColumn("z_um");
  RequireRows(t, kMinFlatnessPoints, "z_um");
  const std::size_t n = t.NumRows();
  {
    // A repeated (x, y): rows sorted by position (ties in file order); the first row in file
    // order that repeats an earlier one is reported, with the line of that earlier one.
    const std::vector<double>& x = t.Column(ix);
    const std::vector<double>& y = t.Column(iy);
    std::vector<std::uint32_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]);
    });
    std::size_t repeat = n, first = n;
    for (std::size_t k = 1; k < n; ++k) {
      const std::uint32_t a = order[k - 1], b = order[k];
      if (x[a] == x[b] && y[a] == y[b] && b < repeat) {
        // b follows the first row of its group when a is that first row; otherwise a later
        // member of the group, which is never the smallest repeat of it.
        repeat = b;
        std::size_t g = k - 1;
        while (g > 0 && x[order[g - 1]] == x[b] && y[order[g - 1]] == y[b]) --g;
        first = order[g];
      }
    }
    if (repeat < n) {
      throw InvalidInput(
          file, t.row_lines[repeat], "x_mm",
          "grid point repeated (first given on line " + std::to_string(t.row_lines[first]) + ")");
    }
  }
  f.grid.x_mm = std::move(t.values[ix]);
  f.grid.y_mm = std::move(t.values[iy]);
  f.grid.z_um = std::move(t.values[iz]);
  // A plane needs three points not on one line: twice the largest triangle area spanned
  // with the first point and the point farthest from it, relative to that distance squared.
  std::size_t far = 0;
  double far_d = 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    const double d = std::hypot(f.grid.x_mm[i] - f.grid.x_mm[0], f.grid.y_mm[i] - f.grid.y_mm[0]);
    if (d > far_d) {
      far_d = d;
      far = i;
    }
  }
  double area = 0.0;
  const double ux = f.grid.x_mm[far] - f.grid.x_mm[0], uy = f.grid.y_mm[far] - f.grid.y_mm[0];
  for (std::size_t i = 1; i < n; ++i) {
    area = std::max(area, std::abs(ux * (f.grid.y_mm[i] - f.grid.y_mm[0]) -
                                   uy * (f.grid.x_mm[i] - f.grid.x_mm[0])));
  }
  if (!(area > 1e-9 * far_d * far_d)) {
    throw InvalidInput(file, t.columns_line, "y_mm",
                       "all grid points lie on one line; flatness needs a surface");
  }
  f.row_lines = std::move(t.row_lines);
  return f;
}

}  // namespace km::ingest
