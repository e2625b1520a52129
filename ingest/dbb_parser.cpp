#include "ingest/dbb_parser.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "analysis/core/errors.h"
#include "analysis/dbb/coverage.h"
#include "ingest/iso8601.h"
#include "ingest/text_format.h"

namespace km::ingest {
namespace {

std::array<double, 3> Vec3(const std::vector<double>& v) {
  return {v[0], v[1], v[2]};
}

void RequirePositive(const TextTable& t, const std::string& key, double v) {
  if (!(v > 0.0)) {
    throw InvalidInput(t.file, t.Find(key)->line, key, "must be greater than zero");
  }
}

// Magnitudes beyond these are not measurements of a machine tool; they would only make the
// analysis overflow. Lengths and positions in mm, bar deviations in µm, angles in degrees.
constexpr double kMaxLengthMm = 1e5;     // 100 m
constexpr double kMaxPositionMm = 1e6;   // 1 km from the machine origin
constexpr double kMaxDeviationUm = 1e6;  // 1 m
constexpr double kMaxFeedMmMin = 1e7;    // 10 km/min
constexpr double kMaxAngleDeg = 1e6;     // some 2 800 turns

std::string Number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// Refuses |v| > limit (a value too large to analyse), naming the field.
void RequireAtMost(const std::string& file, std::size_t line, const std::string& field, double v,
                   double limit, const char* what) {
  if (std::abs(v) > limit) {
    throw InvalidInput(
        file, line, field,
        Number(v) + " is too large to analyse: " + what + " must be within ±" + Number(limit));
  }
}

void RequireHeaderAtMost(const TextTable& t, const std::string& key, double limit,
                         const char* what) {
  const auto* h = t.Find(key);
  if (!h) return;
  for (double v : t.RequireNumbers(key, key == "centre_mm" || key == "fixed_ball_mm" ? 3 : 1)) {
    RequireAtMost(t.file, h->line, key, v, limit, what);
  }
}

void CheckBarUncertainty(const TextTable& t, const std::string& file);

// The header lines of a DBB file: identification, geometry, feed, time and arc, each checked.
dbb::DbbTest ReadHeader(const TextTable& t, const std::string& file) {
  dbb::DbbTest d;
  d.metadata = t.Metadata();
  d.machine_id = t.RequireMachineId();
  d.test_id = t.RequireString("test_id");
  const std::string dir = t.RequireString("direction");
  if (dir == "ccw" || dir == "CCW") {
    d.direction = dbb::Direction::kCcw;
  } else if (dir == "cw" || dir == "CW") {
    d.direction = dbb::Direction::kCw;
  } else {
    throw InvalidInput(file, t.Find("direction")->line, "direction",
                       Quote(dir) + " is neither 'ccw' nor 'cw'");
  }
  if (const auto* p = t.Find("plane")) {
    if (p->value == "XY") {
      d.plane = dbb::Plane::kXY;
    } else if (p->value == "YZ") {
      d.plane = dbb::Plane::kYZ;
    } else if (p->value == "ZX") {
      d.plane = dbb::Plane::kZX;
    } else {
      throw InvalidInput(file, p->line, "plane", Quote(p->value) + " is not XY, YZ or ZX");
    }
  }
  d.bar_length_mm = t.RequireNumber("bar_length_mm");
  RequirePositive(t, "bar_length_mm", d.bar_length_mm);
  d.radius_mm = t.OptionalNumber("radius_mm").value_or(d.bar_length_mm);
  if (t.Has("radius_mm")) RequirePositive(t, "radius_mm", d.radius_mm);
  d.centre_mm = Vec3(t.RequireNumbers("centre_mm", 3));
  d.z_offset_mm = t.OptionalNumber("z_offset_mm").value_or(0.0);
  d.feed_mm_min = t.RequireNumber("feed_mm_min");
  RequirePositive(t, "feed_mm_min", d.feed_mm_min);
  if (auto v = t.OptionalNumbers("tilt_deg", 3)) d.tilt_deg = Vec3(*v);
  d.tool_length_mm = t.OptionalNumber("tool_length_mm");
  if (auto v = t.OptionalNumbers("fixed_ball_mm", 3)) d.fixed_ball_mm = Vec3(*v);
  RequireHeaderAtMost(t, "bar_length_mm", kMaxLengthMm, "a bar length in mm");
  RequireHeaderAtMost(t, "radius_mm", kMaxLengthMm, "a radius in mm");
  RequireHeaderAtMost(t, "tool_length_mm", kMaxLengthMm, "a tool length in mm");
  RequireHeaderAtMost(t, "centre_mm", kMaxPositionMm, "a position in mm");
  RequireHeaderAtMost(t, "fixed_ball_mm", kMaxPositionMm, "a position in mm");
  RequireHeaderAtMost(t, "z_offset_mm", kMaxPositionMm, "an offset in mm");
  RequireHeaderAtMost(t, "feed_mm_min", kMaxFeedMmMin, "a feed in mm/min");
  RequireHeaderAtMost(t, "start_angle_deg", kMaxAngleDeg, "an angle in degrees");
  if (const auto* ts = t.Find("timestamp")) {
    if (ts->value.size() > kMaxIso8601Length) {
      throw InvalidInput(file, ts->line, "timestamp",
                         "the value has " + std::to_string(ts->value.size()) +
                             " characters; an ISO 8601 time has at most " +
                             std::to_string(kMaxIso8601Length));
    }
    if (!ParseIso8601(ts->value)) {
      throw InvalidInput(file, ts->line, "timestamp",
                         Quote(ts->value) + " is not an ISO 8601 time");
    }
    d.timestamp = ts->value;
  }
  d.temperature_c = t.OptionalNumber("temperature_c");
  // Partial arcs (analysis/dbb/coverage.h): the arc the test runs, 180 … 360 degrees.
  if (const auto arc = t.OptionalNumber("arc_deg")) {
    if (!(*arc >= dbb::kMinArcDeg && *arc <= 360.0)) {
      throw InvalidInput(file, t.Find("arc_deg")->line, "arc_deg",
                         Number(*arc) + " is outside " + Number(dbb::kMinArcDeg) +
                             " … 360 degrees (a partial arc of at least " +
                             Number(dbb::kMinArcDeg) + " degrees, or 360 for a full turn)");
    }
    d.arc_deg = *arc;
  }
  CheckBarUncertainty(t, file);
  return d;
}

// The ball bar's uncertainty keys beyond the generic check of every u_* key (text_format.h): the
// bar's growth α·L·δT needs its expansion coefficient α (docs/formats.md §1.1).
void CheckBarUncertainty(const TextTable& t, const std::string& file) {
  const auto alpha = t.OptionalNumber("bar_expansion_ppm_per_k");
  if (alpha && !(*alpha >= 0.0 && *alpha <= 1000.0)) {
    throw InvalidInput(file, t.Find("bar_expansion_ppm_per_k")->line, "bar_expansion_ppm_per_k",
                       Number(*alpha) + " is not an expansion coefficient: 0 … 1000 ppm/K");
  }
  // Plausible sizes: beyond them a value is a typing error, and the draws of a propagation would
  // leave the circle the test describes.
  static const std::pair<const char*, double> kMax[] = {
      {"u_reading_um", 100.0}, {"u_bar_length_um", 1000.0}, {"u_bar_temperature_c", 10.0}};
  for (const auto& [key, most] : kMax) {
    const auto u = t.OptionalNumber(key);
    if (u && *u > most) {
      throw InvalidInput(
          file, t.Find(key)->line, key,
          Number(*u) + " is not a plausible standard uncertainty (at most " + Number(most) + ")");
    }
  }
  if (t.Has("u_bar_temperature_c") && !alpha) {
    throw InvalidInput(file, t.Find("u_bar_temperature_c")->line, "u_bar_temperature_c",
                       "the bar's growth α·L·δT needs its expansion coefficient: state "
                       "bar_expansion_ppm_per_k (e.g. 11.5 for steel, 0 for an invar or "
                       "carbon-fibre bar)");
  }
}

// The samples (angle_deg or t_s, and dr_um) in the order the test ran, and their coverage.
void ReadSamples(const TextTable& t, const std::string& file, dbb::DbbTest& d) {
  const int dr_col = t.ColumnIndex("dr_um");
  const int angle_col = t.ColumnIndex("angle_deg");
  const int time_col = t.ColumnIndex("t_s");
  if (dr_col < 0) {
    throw InvalidInput(file, t.columns_line, "dr_um", "the column 'dr_um' is missing");
  }
  if (angle_col < 0 && time_col < 0) {
    throw InvalidInput(file, t.columns_line, "angle_deg",
                       "neither 'angle_deg' nor 't_s' column is present");
  }
  if (angle_col >= 0 && time_col >= 0) {
    throw InvalidInput(file, t.columns_line, "t_s", "give either 'angle_deg' or 't_s', not both");
  }
  const double sign = d.direction == dbb::Direction::kCcw ? 1.0 : -1.0;
  double start_deg = 0.0;
  if (time_col >= 0) start_deg = t.OptionalNumber("start_angle_deg").value_or(0.0);
  // Angular speed from feed and radius: ω = V / R (deg/s).
  const double omega_deg_s = d.feed_mm_min / 60.0 / d.radius_mm * 180.0 / std::numbers::pi;
  const std::string angle_field = angle_col >= 0 ? "angle_deg" : "t_s";
  d.angle_deg.reserve(t.NumRows());
  d.dr_um.reserve(t.NumRows());
  for (std::size_t i = 0; i < t.NumRows(); ++i) {
    const auto row = t.Row(i);
    const double angle =
        angle_col >= 0 ? row[static_cast<std::size_t>(angle_col)]
                       : start_deg + sign * omega_deg_s * row[static_cast<std::size_t>(time_col)];
    RequireAtMost(file, t.row_lines[i], angle_field, angle, kMaxAngleDeg, "an angle in degrees");
    RequireAtMost(file, t.row_lines[i], "dr_um", row[static_cast<std::size_t>(dr_col)],
                  kMaxDeviationUm, "a bar deviation in µm");
    if (!d.angle_deg.empty()) {
      const double prev = d.angle_deg.back();
      if (!(sign * (angle - prev) > 0.0)) {
        throw InvalidInput(file, t.row_lines[i], angle_field,
                           angle_col >= 0 ? std::string("angles must ") +
                                                (sign > 0 ? "increase (direction ccw)"
                                                          : "decrease (direction cw)") +
                                                " strictly from row to row"
                                          : "times must increase strictly from row to row");
      }
    }
    d.angle_deg.push_back(angle);
    d.dr_um.push_back(row[static_cast<std::size_t>(dr_col)]);
  }
  if (d.angle_deg.empty()) {
    throw InvalidInput(file, t.columns_line, "dr_um", "the file has no data rows");
  }
  // Coverage: one rule for every test (analysis/dbb/coverage.h) — the largest gap between
  // neighbouring samples, the closing gap of a full turn included, is at most 10 degrees; a
  // partial arc (declared arc_deg, or samples that do not come back to their start) is at least
  // 180 degrees long.
  const dbb::Coverage cov = dbb::CheckCoverage(d.angle_deg, d.direction, d.arc_deg);
  if (!cov.ok) {
    const std::size_t line = cov.field == "arc_deg"
                                 ? t.Find("arc_deg")->line
                                 : t.row_lines[std::min(cov.reason_sample, t.row_lines.size() - 1)];
    throw InvalidInput(file, line, cov.field == "arc_deg" ? "arc_deg" : angle_field, cov.reason);
  }
}

}  // namespace

dbb::DbbTest ParseDbb(std::string_view bytes, const std::string& file,
                      const DbbParseOptions& options) {
  ReadOptions ro;
  ro.max_bytes = options.max_bytes;
  ro.max_rows = options.max_samples;
  ro.keep_column = IsDbbColumn;
  const TextTable t = ReadTextTable(bytes, file, ro);
  if (t.format != kDbbFormat) {
    throw InvalidInput(file, t.format_line, "format",
                       "unknown format '" + t.format + "'; expected '" + kDbbFormat + "'");
  }
  return DbbFromTable(t);
}

bool IsDbbColumn(std::string_view c) {
  return c == "angle_deg" || c == "t_s" || c == "dr_um";
}

dbb::DbbTest DbbFromTable(const TextTable& t) {
  dbb::DbbTest d = ReadHeader(t, t.file);
  ReadSamples(t, t.file, d);
  return d;
}

}  // namespace km::ingest
